"""The loops of the renderer's read-back and of the relation engine that numpy runs badly,
compiled with numba.

Some are passes over whole frames or windows that cost more as numpy steps than their
arithmetic: turning the depth and segmentation read-backs into metres and object ids, each
object's box in the segmentation and the statistics of its pixels, cutting a view's silhouettes
(~8,000 projected triangles) into row spans, and following every pixel of a free-space window
down to the platform plane. As
whole-array numpy steps each makes several passes over temporaries as big as the frame; as one
loop each costs a third to a fifth of that. The others are small but asked often, where each
numpy call costs more to set up than its arithmetic: a free-space sector's few thousand cells
(some forty calls a solve), the free-space regions' own test of a placement mask's points,
containment in, clipping by, gaps between and the boxes of ground outlines of up to a hundred
corners, and the camera's framing test. Convex hulls are here too, where scipy's Qhull spent
most of each call setting itself up.

Each loop does the arithmetic of the numpy code it replaced, in the same IEEE operations and order
(numba without ``fastmath`` neither reorders nor fuses them), so every count, mask and cell is the
same bit for bit on the finite coordinates they are given (a NaN would not spread through ``min``
as through numpy's: objects that reach behind the camera are never drawn). The one exception is a
dot product that numpy handed to BLAS, which fuses its multiply and add on CPUs with FMA: here it
is a plain multiply and add (as in the free-space sweep's numpy path, ``free_space._dot``), an ulp
apart at most, which only a point exactly on a region's edge would notice. Compiled once per
machine: numba caches the machine code beside this file (or in the user's cache folder when the
package folder is read-only).
"""

from __future__ import annotations

import numpy as np
from numba import njit


def _compiled(**options):
    """numba's ``njit`` with its on-disk cache, or without it where no folder can hold the cache
    (a read-only install and a read-only home): then each process compiles the loop itself
    (about a second) rather than refusing to import."""
    def wrap(fn):
        try:
            return njit(cache=True, **options)(fn)
        except RuntimeError:  # numba: "cannot cache function ...: no locator available"
            return njit(**options)(fn)
    return wrap


@_compiled()
def union_counts(tris: np.ndarray, sizes: np.ndarray, width: int,
                 height: int) -> np.ndarray:  # pragma: no cover (compiled: coverage cannot see inside)
    """Pixels of a width x height image covered by each set of triangles, those wound positively
    (twice their signed area above 1e-12) drawn.

    ``tris`` (F, 3, 2) pixel coordinates, the sets' triangles one set after another, ``sizes``
    (S,) each set's count. A triangle may cover the centres (row + 0.5) of the rows from
    ceil(lowest y - 0.5) to floor(highest y - 0.5), clipped to the image. A row's span of a
    triangle is the pixel centres left of (or on)
    every edge p -> q: each edge's line crosses the row at px + dx (y - py) / dy, bounding the
    span from the right where the edge goes down the image (dy > 0) and from the left where it
    goes up; a level edge (dy == 0) keeps the row only on its inner side. A set's spans are
    marked +1 at their first pixel and -1 past their last along the rows of the set's box, and
    a pixel is covered where the running sum is positive: overlaps count once.
    """
    n_sets = len(sizes)
    starts = np.zeros(n_sets + 1, np.int64)
    for s in range(n_sets):
        starts[s + 1] = starts[s] + sizes[s]
    r0 = np.zeros(len(tris), np.int64)
    r1 = np.zeros(len(tris), np.int64)  # a triangle not drawn covers no row
    for t in range(len(tris)):
        ax, ay, bx, by, cx, cy = tris[t, 0, 0], tris[t, 0, 1], tris[t, 1, 0], tris[t, 1, 1], tris[t, 2, 0], tris[t, 2, 1]
        if (bx - ax) * (cy - ay) - (by - ay) * (cx - ax) > 1e-12:
            r0[t] = int(min(max(np.ceil(min(ay, by, cy) - 0.5), 0.0), height))
            r1[t] = int(min(max(np.floor(max(ay, by, cy) - 0.5) + 1, 0.0), height))
    counts = np.zeros(n_sets, np.int64)
    spans = 0
    for t in range(len(tris)):
        spans += max(r1[t] - r0[t], 0)
    rows = np.empty(spans, np.int64)
    firsts = np.empty(spans, np.int64)
    lasts = np.empty(spans, np.int64)
    for s in range(n_sets):
        k = 0
        top, bottom, left, right = 1 << 62, -1, 1 << 62, -1
        for t in range(starts[s], starts[s + 1]):
            for r in range(r0[t], r1[t]):
                y = r + 0.5
                lo, hi, ok = -np.inf, np.inf, True
                for e in range(3):
                    px, py = tris[t, e, 0], tris[t, e, 1]
                    f = (e + 1) % 3
                    dx, dy = tris[t, f, 0] - px, tris[t, f, 1] - py
                    w = (y - py) * dx
                    if dy > 0:
                        hi = min(hi, w / dy + px)
                    elif dy < 0:
                        lo = max(lo, w / dy + px)
                    elif w < 0:
                        ok = False
                first = max(np.ceil(lo - 0.5), 0.0)
                last = min(np.floor(hi - 0.5), width - 1.0)
                if ok and last >= first:
                    rows[k], firsts[k], lasts[k] = r, int(first), int(last)
                    top, bottom = min(top, r), max(bottom, r)
                    left, right = min(left, int(first)), max(right, int(last))
                    k += 1
        if k == 0:
            continue
        stride = right - left + 2
        marks = np.zeros((bottom - top + 1) * stride, np.int32)
        for i in range(k):
            at = (rows[i] - top) * stride - left
            marks[at + firsts[i]] += 1
            marks[at + lasts[i] + 1] -= 1
        level, covered = 0, 0
        for i in range(len(marks)):
            level += marks[i]
            if level > 0:
                covered += 1
        counts[s] = covered
    return counts


@_compiled(error_model="numpy")  # a ray along the plane divides by zero: s is inf, as in numpy
def plane_cells(depth: np.ndarray, r0: int, c0: int, rows: int, cols: int, M: np.ndarray, t: np.ndarray,
                z: float, cell_m: float, occlusion_m: float, lo: np.ndarray,
                codes: np.ndarray):  # pragma: no cover (compiled: coverage cannot see inside)
    """For each pixel of the window (rows x cols at r0, c0): where its ray meets the plane at
    height z and which lattice cell's code that point reads.

    The ray through pixel centre (u, w) is M (u, w, 1), scaled so that its camera-frame z is 1
    (M = R K^-1; t the camera's position), so s = (z - t_z) / (M_z . (u, w, 1)) is the optical-axis
    depth at which it meets the plane; the pixel sees the plane where s > 0 and the rendered depth
    lies within ``occlusion_m`` of s. Its point is t + s M (u, w, 1), its cell floor(point /
    cell_m) - lo in ``codes`` (rows following y). Returns the window's codes (0 where unseen or
    off the codes) and, in row-major order, the flat window index and plane point of every pixel
    whose code is not 0.
    """
    out = np.zeros((rows, cols), np.uint8)
    n = 0
    at = np.empty(rows * cols, np.int64)
    xs = np.empty(rows * cols, np.float64)
    ys = np.empty(rows * cols, np.float64)
    height = z - t[2]
    code_rows, code_cols = codes.shape
    for i in range(rows):
        w = r0 + i + 0.5
        for j in range(cols):
            u = c0 + j + 0.5
            s = height / (M[2, 0] * u + M[2, 1] * w + M[2, 2])
            if not (s > 0 and abs(np.float64(depth[r0 + i, c0 + j]) - s) <= occlusion_m):
                continue
            x = ((u * M[0, 0] + w * M[0, 1]) + M[0, 2]) * s + t[0]
            y = ((u * M[1, 0] + w * M[1, 1]) + M[1, 2]) * s + t[1]
            ix = int(np.floor(x / cell_m)) - lo[0]
            iy = int(np.floor(y / cell_m)) - lo[1]
            if 0 <= ix < code_cols and 0 <= iy < code_rows and codes[iy, ix] != 0:
                out[i, j] = codes[iy, ix]
                at[n], xs[n], ys[n] = i * cols + j, x, y
                n += 1
    return out, at[:n], xs[:n], ys[:n]


@_compiled()
def metres_upright(raw: np.ndarray, near: float, far: float) -> np.ndarray:  # pragma: no cover (compiled)
    """A reversed-Z depth read-back (float32, OpenGL's rows bottom-up) as metres along the optical
    axis, rows top-down: n f / (n + raw (f - n)) in float64 (platform.md), stored as float32."""
    h, w = raw.shape
    out = np.empty((h, w), np.float32)
    span, product = far - near, near * far
    for i in range(h):
        row = h - 1 - i
        for j in range(w):
            out[i, j] = product / (raw[row, j] * span + near)
    return out


@_compiled()
def ids_upright(colours: np.ndarray, table: np.ndarray) -> np.ndarray:  # pragma: no cover (compiled)
    """A segmentation read-back (uint8 RGB codes, OpenGL's rows bottom-up) as ``table``'s value for
    each code r | g << 8 | b << 16, rows top-down; a code past the table reads its last entry."""
    h, w, _ = colours.shape
    out = np.empty((h, w), np.int32)
    last = len(table) - 1
    for i in range(h):
        row = h - 1 - i
        for j in range(w):
            code = np.int64(colours[row, j, 0]) | np.int64(colours[row, j, 1]) << 8 | np.int64(colours[row, j, 2]) << 16
            out[i, j] = table[min(code, last)]
    return out


@_compiled()
def sector_cells(free: np.ndarray, raster_first: np.ndarray, first: np.ndarray, last: np.ndarray,
                 centre: np.ndarray, axis: np.ndarray, reach: float, cos_half: float,
                 cell_m: float):  # pragma: no cover (compiled: coverage cannot see inside)
    """The free cells of a platform raster within the lattice box first..last (inclusive (x, y)
    indices) that lie in a circular sector, and how many free cells the box holds.

    ``free`` is the raster (rows following y) whose cell (0, 0) has index ``raster_first``; a cell
    off it is not free. A cell's centre p = (index + 0.5) cell_m is in the sector (apex ``centre``,
    unit ``axis``, radius ``reach``, half-angle with cosine ``cos_half``) when, with r = p - centre,
    |r| > 1e-9, |r| <= reach and r . axis >= cos_half |r|. Returns (free cells in the box, then
    of those in the sector in row-major order: raster rows, raster columns, x, y)."""
    rows = max(last[1] - first[1] + 1, 0)
    cols = max(last[0] - first[0] + 1, 0)
    n_rows, n_cols = free.shape
    out_r = np.empty(rows * cols, np.int64)
    out_c = np.empty(rows * cols, np.int64)
    xs = np.empty(rows * cols, np.float64)
    ys = np.empty(rows * cols, np.float64)
    in_box, n = 0, 0
    for i in range(rows):
        r = first[1] + i - raster_first[1]
        if r < 0 or r >= n_rows:
            continue
        y = (first[1] + i + 0.5) * cell_m
        ry = y - centre[1]
        for j in range(cols):
            c = first[0] + j - raster_first[0]
            if c < 0 or c >= n_cols or not free[r, c]:
                continue
            in_box += 1
            x = (first[0] + j + 0.5) * cell_m
            rx = x - centre[0]
            dist = np.sqrt(rx * rx + ry * ry)
            if rx * axis[0] + ry * axis[1] >= cos_half * dist and dist <= reach and dist > 1e-9:
                out_r[n], out_c[n], xs[n], ys[n] = r, c, x, y
                n += 1
    return in_box, out_r[:n], out_c[:n], xs[:n], ys[:n]


@_compiled()
def strip_answer(rows: np.ndarray, cols: np.ndarray, xs: np.ndarray, ys: np.ndarray, seen: np.ndarray,
                 cleared: np.ndarray, roomy: np.ndarray, axis: np.ndarray, across: np.ndarray, lo: float,
                 hi: float, stop: float):  # pragma: no cover (compiled: coverage cannot see inside)
    """Of a sector's free cells (raster ``rows``, ``cols``; centres ``xs``, ``ys``): how many are
    seen, and of the seen ones those also cleared and roomy whose centre lies in the strip (lo <=
    p . across <= hi, p . axis <= stop): their count, the mean of their centres (summed in order,
    as numpy's column mean), and the one nearest to that mean (the first of equals)."""
    visible, n = 0, 0
    sx, sy = 0.0, 0.0
    keep = np.zeros(len(rows), np.bool_)
    for k in range(len(rows)):
        r, c = rows[k], cols[k]
        if not seen[r, c]:
            continue
        visible += 1
        x, y = xs[k], ys[k]
        lateral = x * across[0] + y * across[1]
        if (cleared[r, c] and roomy[r, c] and lateral >= lo and lateral <= hi
                and x * axis[0] + y * axis[1] <= stop):
            keep[k] = True
            sx += x
            sy += y
            n += 1
    mean = np.array([sx / n, sy / n]) if n else np.zeros(2)
    nearest = np.zeros(2)
    best = np.inf
    for k in range(len(rows)):
        if keep[k]:
            dx, dy = xs[k] - mean[0], ys[k] - mean[1]
            d = np.sqrt(dx * dx + dy * dy)
            if d < best:
                best = d
                nearest[0], nearest[1] = xs[k], ys[k]
    return visible, n, mean, nearest


# A corner closer to the line through its neighbours than this (as twice the triangle's area, m^2)
# is on that line. Outlines are rounded to whole micrometres, where three points off one line
# make at least 1e-12; points on one line make a few 1e-17 of rounding. Qhull drops those too.
COLLINEAR_CROSS = 1e-15


@_compiled()
def convex_ring(points: np.ndarray) -> np.ndarray:  # pragma: no cover (compiled: coverage cannot see inside)
    """Indices of the corners of the convex hull of (N, 2) points, counter-clockwise from the
    lowest (then leftmost) corner, points on an edge left out (Andrew's monotone chain; a
    duplicate point may be named by either index). Qhull through scipy found the same corners
    for every ground outline and footprint pair of 270 scenes, in 30-200 us a call against 1-60
    here: most of Qhull's time is setting itself up. Fewer than three corners raise ValueError."""
    n = len(points)
    order = np.argsort(points[:, 0])
    for i in range(1, n):  # points level in x follow y (an insertion sort: such runs are short)
        p, j = order[i], i
        while j > 0 and points[order[j - 1], 0] == points[p, 0] and points[order[j - 1], 1] > points[p, 1]:
            order[j] = order[j - 1]
            j -= 1
        order[j] = p
    ring = np.empty(2 * n, np.int64)
    k = 0
    for m in range(n):  # the lower chain, left to right
        k = _turn_left(points, ring, k, 2, order[m])
    upper = k + 1
    for m in range(n - 2, -1, -1):  # the upper chain, right to left, back to the first point
        k = _turn_left(points, ring, k, upper, order[m])
    k -= 1  # the first point, met again
    if k < 3:
        raise ValueError("convex_ring: the points lie on one line")
    # The ring begins at its leftmost corner and runs along the bottom first: the first of the
    # lowest corners met is the leftmost of them.
    start = 0
    for m in range(1, k):
        if points[ring[m], 1] < points[ring[start], 1]:
            start = m
    out = np.empty(k, np.int64)
    for m in range(k):
        out[m] = ring[(start + m) % k]
    return out


@_compiled()
def _turn_left(points: np.ndarray, ring: np.ndarray, k: int, floor: int,
               p: int) -> int:  # pragma: no cover (compiled: coverage cannot see inside)
    """Append point ``p`` to the chain ``ring[:k]``, first dropping its last points while they do
    not turn left on the way to ``p`` (keeping ``floor`` - 1 of them); returns the new length."""
    while k >= floor:
        a, b = ring[k - 2], ring[k - 1]
        cross = ((points[b, 0] - points[a, 0]) * (points[p, 1] - points[a, 1])
                 - (points[b, 1] - points[a, 1]) * (points[p, 0] - points[a, 0]))
        if cross > COLLINEAR_CROSS:
            break
        k -= 1
    ring[k] = p
    return k + 1


@_compiled()
def in_frame(uv: np.ndarray, z: np.ndarray, near: float, margin: float, width: float,
             height: float) -> bool:  # pragma: no cover (compiled: coverage cannot see inside)
    """Whether every projected point (pixels ``uv``, depth ``z``) lies beyond ``near`` and at least
    ``margin`` inside the image: the camera's framing test, asked some sixty times a scene by its
    bisection, in one pass instead of four numpy reductions (a NaN fails, as there)."""
    for i in range(len(z)):
        u, v = uv[i, 0], uv[i, 1]
        if not (z[i] > near and u >= margin and v >= margin and u <= width - margin and v <= height - margin):
            return False
    return True


@_compiled()
def boxes_meet(a: np.ndarray, b: np.ndarray) -> bool:  # pragma: no cover (compiled: coverage cannot see inside)
    """Whether the axis-aligned bounding boxes of two (N, 2) point sets touch or overlap: when
    they do not, neither do the polygons, and most pairs in a scene are told apart by this alone
    (numpy's reductions and comparisons took 23 us a pair of outlines, this 0.7 us)."""
    return (a[:, 0].min() <= b[:, 0].max() and a[:, 1].min() <= b[:, 1].max()
            and b[:, 0].min() <= a[:, 0].max() and b[:, 1].min() <= a[:, 1].max())


@_compiled()
def polygon_gap(a: np.ndarray, b: np.ndarray) -> float:  # pragma: no cover (compiled: coverage cannot see inside)
    """Smallest distance between two convex polygons ((N, 2) corners in order), 0 when they
    overlap or touch: no edge normal of either separates their corners' shadows, or else the
    least distance from a corner of one to an edge of the other (the nearest point of an edge is
    its start plus t, clipped to [0, 1], times the edge). Squared distances are compared and one
    square root taken: the root rounds monotonically, so it is the least of the roots."""
    if boxes_meet(a, b):
        separated = False
        for p in (a, b):
            for k in range(len(p)):
                f = (k + 1) % len(p)
                nx, ny = p[f, 1] - p[k, 1], -(p[f, 0] - p[k, 0])
                a_lo, a_hi, b_lo, b_hi = np.inf, -np.inf, np.inf, -np.inf
                for i in range(len(a)):
                    s = a[i, 0] * nx + a[i, 1] * ny
                    a_lo, a_hi = min(a_lo, s), max(a_hi, s)
                for i in range(len(b)):
                    s = b[i, 0] * nx + b[i, 1] * ny
                    b_lo, b_hi = min(b_lo, s), max(b_hi, s)
                if a_hi < b_lo or b_hi < a_lo:
                    separated = True
                    break
            if separated:
                break
        if not separated:
            return 0.0
    best = np.inf
    for p, q in ((a, b), (b, a)):
        for k in range(len(q)):
            f = (k + 1) % len(q)
            sx, sy = q[k, 0], q[k, 1]
            dx, dy = q[f, 0] - sx, q[f, 1] - sy
            dd = max(dx * dx + dy * dy, 1e-12)
            for m in range(len(p)):
                t = min(max(((p[m, 0] - sx) * dx + (p[m, 1] - sy) * dy) / dd, 0.0), 1.0)
                ex, ey = p[m, 0] - (sx + t * dx), p[m, 1] - (sy + t * dy)
                best = min(best, ex * ex + ey * ey)
    return np.sqrt(best)


@_compiled()
def _inside(x: float, y: float, normals: np.ndarray, offsets: np.ndarray,
            grow: float) -> bool:  # pragma: no cover (compiled: coverage cannot see inside)
    """p . normal - offset <= grow for every half-plane, the point rejected at the first it lies
    beyond (a NaN coordinate is never inside, as in numpy's ``all``)."""
    for k in range(len(offsets)):
        if not (x * normals[k, 0] + y * normals[k, 1] - offsets[k] <= grow):
            return False
    return True


@_compiled()
def inside_planes(points: np.ndarray, normals: np.ndarray, offsets: np.ndarray,
                  grow: float) -> np.ndarray:  # pragma: no cover (compiled: coverage cannot see inside)
    """Whether each of (N, 2) points lies in every half-plane (K outward unit normals, K offsets):
    inside the convex polygon they bound, grown by ``grow`` (``_inside``), where the whole-array
    test worked out every point against every edge of an outline with up to a hundred corners."""
    out = np.empty(len(points), np.bool_)
    for i in range(len(points)):
        out[i] = _inside(points[i, 0], points[i, 1], normals, offsets, grow)
    return out


@_compiled()
def inside_planes_grid(xs: np.ndarray, ys: np.ndarray, normals: np.ndarray, offsets: np.ndarray,
                       grow: float) -> np.ndarray:  # pragma: no cover (compiled: coverage cannot see inside)
    """``inside_planes`` of every grid point (x, y), x from ``xs`` and y from ``ys``, as a
    (len(ys), len(xs)) mask (rows follow y), without making the points."""
    out = np.empty((len(ys), len(xs)), np.bool_)
    for i in range(len(ys)):
        for j in range(len(xs)):
            out[i, j] = _inside(xs[j], ys[i], normals, offsets, grow)
    return out


@_compiled()
def clip_polygon(subject: np.ndarray, clip: np.ndarray) -> np.ndarray:  # pragma: no cover (compiled)
    """Sutherland-Hodgman: the convex polygon ``subject`` cut by each edge a -> b of the convex
    ``clip`` in turn (both counter-clockwise). A corner p is inside an edge where its side,
    (b - a) x (p - a), is >= 0; an edge that leaves every corner inside changes nothing, and one
    that does not keeps, for each corner p and its successor q, p if inside, then the crossing
    p + (q - p) (s_p / (s_p - s_q)) if the two lie on different sides."""
    out = subject.copy()
    for k in range(len(clip)):
        n = len(out)
        if n == 0:
            break
        f = (k + 1) % len(clip)
        ax, ay = clip[k, 0], clip[k, 1]
        ex, ey = clip[f, 0] - ax, clip[f, 1] - ay
        side = np.empty(n)
        cuts = False
        for i in range(n):
            side[i] = ex * (out[i, 1] - ay) - ey * (out[i, 0] - ax)
            cuts = cuts or side[i] < 0
        if not cuts:
            continue
        kept = np.empty((2 * n, 2))
        m = 0
        for i in range(n):
            j = (i + 1) % n
            if side[i] >= 0:
                kept[m, 0], kept[m, 1] = out[i, 0], out[i, 1]
                m += 1
            if (side[i] >= 0) != (side[j] >= 0):
                t = side[i] / (side[i] - side[j])
                kept[m, 0] = out[i, 0] + (out[j, 0] - out[i, 0]) * t
                kept[m, 1] = out[i, 1] + (out[j, 1] - out[i, 1]) * t
                m += 1
        out = kept[:m].copy()
    return out


@_compiled()
def label_boxes(labels: np.ndarray, count: int) -> np.ndarray:  # pragma: no cover (compiled)
    """For each label 0..count-1 of a (H, W) integer image, the box around its pixels as (first
    row, past the last row, first column, past the last column), all -1 where it has none;
    negative labels are background. One pass, where ``scipy.ndimage.find_objects`` makes its
    own of a shifted copy."""
    out = np.full((count, 4), -1, np.int64)
    h, w = labels.shape
    for r in range(h):
        c = 0
        while c < w:
            # A run of one label along the row: only its ends can widen the label's box, so the
            # box is read and written once a run, not once a pixel (runs are tens of pixels long).
            k, start = labels[r, c], c
            c += 1
            while c < w and labels[r, c] == k:
                c += 1
            if k < 0 or k >= count:
                continue
            if out[k, 0] < 0:
                out[k, 0], out[k, 1], out[k, 2], out[k, 3] = r, r + 1, start, c
            else:
                out[k, 1] = r + 1
                out[k, 2] = min(out[k, 2], start)
                out[k, 3] = max(out[k, 3], c)
    return out


@_compiled()
def object_pixels(seg: np.ndarray, depth: np.ndarray, rgb: np.ndarray, r0: int, r1: int, c0: int, c1: int,
                  object_id: int):  # pragma: no cover (compiled: coverage cannot see inside)
    """One pass over an object's box (rows r0..r1, columns c0..c1, ends excluded): its pixel
    count, the sums of their rows and of their columns, of each colour channel (``rgb`` may have
    no rows: then 0) and their median depth, as numpy's median has it for float32 (the middle
    value, or the mean of the two middle ones, summed in the depths' precision; NaN when there is
    no pixel). Every sum is a whole number, so it is exact in any order."""
    n, row_sum, col_sum = 0, 0, 0
    red, green, blue = 0, 0, 0
    values = np.empty((r1 - r0) * (c1 - c0), depth.dtype)
    colours = rgb.shape[0] > 0
    for i in range(r0, r1):
        for j in range(c0, c1):
            if seg[i, j] == object_id:
                values[n] = depth[i, j]
                n += 1
                row_sum += i
                col_sum += j
                if colours:
                    red += rgb[i, j, 0]
                    green += rgb[i, j, 1]
                    blue += rgb[i, j, 2]
    median = np.nan
    if n > 0:
        k = n // 2
        ordered = np.partition(values[:n], k)
        median = ordered[k]
        if n % 2 == 0:  # and the largest below it, the (k - 1)-th smallest: their sum in the depths'
            median = (ordered[:k].max() + median) / 2  # own precision, halved (exactly, in float64)
    return n, row_sum, col_sum, red, green, blue, median


# Region kinds of ``in_regions``: what ``free_space.REGIONS`` tests, in its arithmetic.
SECTOR, BETWEEN, ON_TOP, OFFSET = 0, 1, 2, 3


@_compiled()
def _in_every_region(x: float, y: float, kinds: np.ndarray, params: np.ndarray, spans: np.ndarray,
                     normals: np.ndarray, offsets: np.ndarray) -> bool:  # pragma: no cover (compiled)
    """Whether (x, y) lies in every region: a sector (params: apex x, y, unit axis x, y, radius,
    cosine of the half-angle) holds p where, with r = p - apex, r . axis >= cosine |r|,
    |r| <= radius and |r| > 1e-9; a between region is the convex polygon of the half-planes
    normals[spans[k, 0]:spans[k, 1]] (``_inside``); an on-top region holds every point (the
    platform is the shrunk top); an offset (params: target x, y, then the limit in the radius
    column) holds p within the limit of the target."""
    for k in range(len(kinds)):
        kind = kinds[k]
        if kind == SECTOR:
            rx, ry = x - params[k, 0], y - params[k, 1]
            dist = np.sqrt(rx * rx + ry * ry)
            if not (rx * params[k, 2] + ry * params[k, 3] >= params[k, 5] * dist and dist <= params[k, 4]
                    and dist > 1e-9):
                return False
        elif kind == BETWEEN:
            lo, hi = spans[k, 0], spans[k, 1]
            if not _inside(x, y, normals[lo:hi], offsets[lo:hi], 0.0):
                return False
        elif kind == OFFSET:
            dx, dy = x - params[k, 0], y - params[k, 1]
            if not np.sqrt(dx * dx + dy * dy) <= params[k, 4]:
                return False
    return True


@_compiled()
def in_regions(points: np.ndarray, kinds: np.ndarray, params: np.ndarray, spans: np.ndarray, normals: np.ndarray,
               offsets: np.ndarray) -> np.ndarray:  # pragma: no cover (compiled: coverage cannot see inside)
    """``_in_every_region`` of each of (N, 2) points."""
    out = np.empty(len(points), np.bool_)
    for i in range(len(points)):
        out[i] = _in_every_region(points[i, 0], points[i, 1], kinds, params, spans, normals, offsets)
    return out


@_compiled()
def in_regions_grid(xs: np.ndarray, ys: np.ndarray, kinds: np.ndarray, params: np.ndarray, spans: np.ndarray,
                    normals: np.ndarray, offsets: np.ndarray) -> np.ndarray:  # pragma: no cover (compiled)
    """``_in_every_region`` of every grid point (x, y), x from ``xs`` and y from ``ys``, as a
    (len(ys), len(xs)) mask (rows follow y), without making the points."""
    out = np.empty((len(ys), len(xs)), np.bool_)
    for i in range(len(ys)):
        for j in range(len(xs)):
            out[i, j] = _in_every_region(xs[j], ys[i], kinds, params, spans, normals, offsets)
    return out


@_compiled()
def unknown_cells(known: np.ndarray, rows: np.ndarray,
                  cols: np.ndarray):  # pragma: no cover (compiled: coverage cannot see inside)
    """The (rows, columns) of the cells given that ``known`` does not hold yet, in their order."""
    n = 0
    for i in range(len(rows)):
        if not known[rows[i], cols[i]]:
            n += 1
    out_rows, out_cols = np.empty(n, np.int64), np.empty(n, np.int64)
    k = 0
    for i in range(len(rows)):
        if not known[rows[i], cols[i]]:
            out_rows[k], out_cols[k] = rows[i], cols[i]
            k += 1
    return out_rows, out_cols


@_compiled()
def cell_points(rows: np.ndarray, cols: np.ndarray, first_x: int, first_y: int, z: float,
                cell: float) -> np.ndarray:  # pragma: no cover (compiled: coverage cannot see inside)
    """(N, 3) points at the centres of raster cells at height z: ((column or row) + first + 0.5)
    times the cell size, in x and y, numpy's operations in numpy's order (the index sum as an
    integer, then a float)."""
    out = np.empty((len(rows), 3))
    for i in range(len(rows)):
        out[i, 0] = (np.float64(cols[i] + first_x) + 0.5) * cell
        out[i, 1] = (np.float64(rows[i] + first_y) + 0.5) * cell
        out[i, 2] = z
    return out


@_compiled()
def mark_view_flags(uv: np.ndarray, z: np.ndarray, depth: np.ndarray, clear: np.ndarray, occlusion_m: float,
                    rows: np.ndarray, cols: np.ndarray, seen: np.ndarray, cleared: np.ndarray,
                    known: np.ndarray) -> None:  # pragma: no cover (compiled: coverage cannot see inside)
    """For each projected point (pixel coordinates ``uv``, optical-axis depth ``z``), set its
    cell's flags (``rows``, ``cols`` of rasters ``seen``, ``cleared`` and ``known``): seen where its
    pixel floor(uv) lies on the image and the rendered ``depth`` there is within ``occlusion_m`` of
    z, for z > 0; cleared where ``clear`` holds that pixel; known in any case. A point off the
    image is neither seen nor cleared; a coordinate that is not finite is off the image."""
    h, w = depth.shape
    for i in range(len(uv)):
        u, v = uv[i, 0], uv[i, 1]
        is_seen, is_cleared = False, False
        if 0 <= u < w and 0 <= v < h:  # floor(u) in 0..w-1 exactly when u is in [0, w)
            col, row = int(np.floor(u)), int(np.floor(v))
            is_cleared = clear[row, col]
            is_seen = z[i] > 0 and abs(np.float64(depth[row, col]) - z[i]) <= occlusion_m
        seen[rows[i], cols[i]] = is_seen
        cleared[rows[i], cols[i]] = is_cleared
        known[rows[i], cols[i]] = True
