"""Shape builders: sampled parameters -> a visual mesh and convex collision parts.

Each builder works in the object frame (origin at the footprint centre on the
resting surface, +z up, +x the semantic front, metres) and is registered under
the name the catalogue's ``builder`` key uses, with the parameters it reads and
the limits its ranges must respect (checked when the catalogue loads).
"""

from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np
import trimesh

Built = tuple[trimesh.Trimesh, list[trimesh.Trimesh]]  # (visual mesh, convex collision parts)
Builder = Callable[[dict[str, float]], Built]

BUILDERS: dict[str, Builder] = {}
BUILDER_PARAMS: dict[str, tuple[str, ...]] = {}  # parameter names each builder reads
BUILDER_LIMITS: dict[str, tuple[str, ...]] = {}  # "small*k <= big" rules on the catalogue ranges

SEGMENTS = 32  # around revolved shapes: smooth at 960x540, cheap for a CPU rasteriser
WALL_PARTS = 12  # convex wedges around a rim; a multiple of 4 keeps the +-x/+-y extremes exact

# ---------------------------------------------------------------- geometry helpers


def register(name: str, needs: str, *limits: str) -> Callable[[Builder], Builder]:
    """Add a builder. `needs` (space-separated names) and `limits` ("small*k <= big", big a
    parameter or a number) let the loader reject catalogue entries the builder cannot build."""

    def add(fn: Builder) -> Builder:
        BUILDERS[name], BUILDER_PARAMS[name], BUILDER_LIMITS[name] = fn, tuple(needs.split()), limits
        return fn

    return add


def _outward(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def _revolve(profile: Any) -> trimesh.Trimesh:
    """Revolve an (r, z) profile about +z; both ends on the axis give a closed solid."""
    return _outward(trimesh.creation.revolve(np.asarray(profile, dtype=float), sections=SEGMENTS))


def _arc(cr: float, cz: float, radius: float, a0: float, a1: float, n: int = 7) -> list[tuple[float, float]]:
    """Points on a circular arc in the (r, z) plane, for rounded rims and edges."""
    return [(cr + radius * math.cos(a), cz + radius * math.sin(a)) for a in np.linspace(a0, a1, n)]


def _lip(r_out: float, r_in: float, top: float) -> list[tuple[float, float]]:
    """A rounded rim from the outer to the inner wall whose crest is exactly at `top`."""
    half = (r_out - r_in) / 2
    return _arc(r_in + half, top - half, half, 0.0, math.pi)


def _union(meshes: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    return _outward(trimesh.boolean.union(meshes, engine="manifold"))


def _hull(points: np.ndarray) -> trimesh.Trimesh:
    return trimesh.convex.convex_hull(np.asarray(points, dtype=float))


def _container_parts(outer: np.ndarray, inner: np.ndarray, base_r: float, base_z: float, bands: int = 1) -> list:
    """A base slab plus WALL_PARTS hulls of wall wedges per height band, so the cavity stays open
    for things resting inside. A curved wall needs bands: one hull per wedge would fill the
    cavity up to the chord of the profile."""
    parts = [trimesh.creation.cylinder(radius=base_r, segment=[[0, 0, 0], [0, 0, base_z]], sections=WALL_PARTS)]
    angles = np.linspace(0, 2 * math.pi, WALL_PARTS + 1)
    cuts = np.linspace(0, len(outer) - 1, bands + 1).round().astype(int)
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        rz = np.vstack([outer[lo : hi + 1], inner[lo : hi + 1]])
        for a0, a1 in zip(angles[:-1], angles[1:]):
            wedge = [np.column_stack([rz[:, 0] * math.cos(a), rz[:, 0] * math.sin(a), rz[:, 1]]) for a in (a0, a1)]
            parts.append(_hull(np.vstack(wedge)))
    return parts


def _tube_rings(path: np.ndarray, radii: np.ndarray, up: np.ndarray, around: int, ridges: int = 0) -> np.ndarray:
    """(n, around, 3) circles, optionally ridged, swept along a path that runs across `up`; each
    ring spans `up` and the horizontal normal, so its lowest point is exactly one radius below."""
    side = np.cross(up, np.gradient(path, axis=0))
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    phi = np.linspace(0, 2 * math.pi, around, endpoint=False)
    r = radii[:, None] * (1 + 0.06 * np.cos(ridges * phi) * bool(ridges))[None, :]
    offsets = np.cos(phi)[None, :, None] * side[:, None, :] + np.sin(phi)[None, :, None] * up
    return path[:, None, :] + r[:, :, None] * offsets


def _tube(rings: np.ndarray, path: np.ndarray) -> trimesh.Trimesh:
    """Closed tube through the rings, with flat caps fanned from the path's end points."""
    n, m = rings.shape[:2]
    i, j = np.meshgrid(np.arange(n - 1), np.arange(m), indexing="ij")
    a, b = i * m + j, i * m + (j + 1) % m
    sides = np.vstack([np.stack([a, a + m, b + m], -1).reshape(-1, 3), np.stack([a, b + m, b], -1).reshape(-1, 3)])
    j, last = np.arange(m), (n - 1) * m
    start = np.column_stack([np.full(m, n * m), j, (j + 1) % m])
    end = np.column_stack([np.full(m, n * m + 1), last + (j + 1) % m, last + j])
    return _outward(trimesh.Trimesh(np.vstack([rings.reshape(-1, 3), path[[0, -1]]]), np.vstack([sides, start, end])))


def _finish(visual: trimesh.Trimesh, parts: list, centre: bool = True, height: float | None = None) -> Built:
    """Move into the object frame: lowest point on z=0, footprint centred on the origin (unless
    the builder already centred the main body), optionally scaled uniformly to an exact height."""
    lo, hi = visual.bounds
    shift = -np.array([(lo[0] + hi[0]) / 2 * centre, (lo[1] + hi[1]) / 2 * centre, lo[2]])
    scale = 1.0 if height is None else height / (hi[2] - lo[2])
    for mesh in (visual, *parts):
        mesh.apply_translation(shift)
        mesh.apply_scale(scale)
    return visual, parts


# ---------------------------------------------------------------- builders


@register(
    "mug", "radius_m height_m wall_m base_m handle_reach_m handle_radius_m",
    "wall_m*3 <= radius_m", "base_m*4 <= height_m", "handle_radius_m*7 <= height_m",
    "handle_radius_m*2 <= handle_reach_m",
)
def build_mug(p: dict[str, float]) -> Built:
    """Hollow cylinder (radius_m, height_m, wall_m, base_m) with a rounded rim and a D-shaped
    handle of round section on +x (handle_reach_m out of the wall, handle_radius_m thick).
    The body, not the footprint, is centred on the origin."""
    r, h, w, b = p["radius_m"], p["height_m"], p["wall_m"], p["base_m"]
    body = _revolve([(0, 0), (r, 0), *_lip(r, r - w, h), (r - w, b), (0, b)])
    t = np.linspace(0, math.pi, 17)
    path = np.column_stack([r - w / 2 + (p["handle_reach_m"] + w / 2) * np.sin(t), 0 * t, h * (0.55 + 0.3 * np.cos(t))])
    handle = _tube(_tube_rings(path, np.full(len(t), p["handle_radius_m"]), np.array([0.0, 1.0, 0.0]), 12), path)
    walls = _container_parts(np.array([(r, 0), (r, h)]), np.array([(r - w, b), (r - w, h)]), r, b)
    return _finish(_union([body, handle]), walls + [handle.convex_hull], centre=False)


@register(
    "cup", "radius_bottom_m radius_top_m height_m wall_m base_m",
    "radius_bottom_m*1 <= radius_top_m", "wall_m*3 <= radius_bottom_m", "base_m*4 <= height_m",
)
def build_cup(p: dict[str, float]) -> Built:
    """Hollow tapered tumbler: radius_bottom_m at the foot, radius_top_m at the rounded rim,
    height_m tall, wall_m thick walls, base_m thick bottom."""
    rb, rt, h, w, b = p["radius_bottom_m"], p["radius_top_m"], p["height_m"], p["wall_m"], p["base_m"]
    rib = rb - w + (rt - rb) * b / h  # inner wall radius at the top of the base
    visual = _revolve([(0, 0), (rb, 0), *_lip(rt, rt - w, h), (rib, b), (0, b)])
    return _finish(visual, _container_parts(np.array([(rb, 0), (rt, h)]), np.array([(rib, b), (rt - w, h)]), rb, b))


_BOWL_SWEEP = 0.45 * math.pi  # how far the wall turns, from flat at the foot to near-vertical at the rim


@register(
    "bowl", "radius_m base_radius_m height_m wall_m base_m",
    "base_radius_m*1.2 <= radius_m", "wall_m*3 <= base_radius_m", "base_m*3 <= height_m",
)
def build_bowl(p: dict[str, float]) -> Built:
    """Hollow revolved bowl: flat bottom of base_radius_m, a wall curving up to radius_m at a
    rounded rim height_m high, wall_m thick walls, base_m thick bottom. Walls in two bands."""
    R, rb, h, w, b = p["radius_m"], p["base_radius_m"], p["height_m"], p["wall_m"], p["base_m"]
    a = np.linspace(0, _BOWL_SWEEP, 11)
    s, c = np.sin(a) / math.sin(_BOWL_SWEEP), (1 - np.cos(a)) / (1 - math.cos(_BOWL_SWEEP))
    outer = np.column_stack([rb + (R - rb) * s, (h - w / 2) * c])
    inner = np.column_stack([rb - w + (R - rb) * s, b + (h - w / 2 - b) * c])  # up by the base, in by the wall
    visual = _revolve([(0, 0), *outer, *_lip(R, R - w, h)[1:-1], *inner[::-1], (0, b)])
    parts = _container_parts(np.vstack([outer, [(R, h)]]), np.vstack([inner, [(R - w, h)]]), rb, b, bands=2)
    return _finish(visual, parts)


@register("plate", "radius_m rim_width_m height_m thickness_m",
          "rim_width_m*2 <= radius_m", "thickness_m*3.4 <= height_m")
def build_plate(p: dict[str, float]) -> Built:
    """Flat dish: a well of radius_m - rim_width_m and a rim sloping up to radius_m at height_m,
    thickness_m thick, with a rounded outer edge. One hull: a plate is shallow."""
    R, h, t = p["radius_m"], p["height_m"], p["thickness_m"]
    rw, k = R - p["rim_width_m"], 0.4 * h
    edge = _arc(R - t / 2, h - t / 2, t / 2, -math.pi / 2, math.pi / 2)
    top = [(rw - 0.3 * t, k + t), (0.75 * rw - 0.3 * t, t), (0, t)]
    visual = _revolve([(0, 0), (0.75 * rw, 0), (rw, k), *edge, *top])
    return _finish(visual, [visual.convex_hull])


@register(
    "bottle", "radius_m height_m neck_radius_m neck_m shoulder_m",
    "neck_radius_m*1.3 <= radius_m", "neck_m*3 <= height_m", "shoulder_m*3 <= height_m",
)
def build_bottle(p: dict[str, float]) -> Built:
    """Solid revolved bottle: a cylinder of radius_m, a shoulder_m tall curve in to a neck of
    neck_radius_m and neck_m length topped by a slightly wider cap; height_m overall."""
    R, h, rn, neck, sh = p["radius_m"], p["height_m"], p["neck_radius_m"], p["neck_m"], p["shoulder_m"]
    body, e, rc, cap = h - neck - sh, 0.1 * R, 1.12 * rn, 0.35 * neck
    u = np.linspace(0, 1, 9)
    shoulder = np.column_stack([rn + (R - rn) * (1 + np.cos(math.pi * u)) / 2, body + sh * u])
    visual = _revolve([(0, 0), (R - e, 0), (R, e), *shoulder, (rn, h - cap), (rc, h - cap), (rc, h), (0, h)])
    return _finish(visual, [visual.convex_hull])


@register("can", "radius_m height_m")
def build_can(p: dict[str, float]) -> Built:
    """Drink can of radius_m and height_m: domed bottom, necked top, raised rim (scaled by the radius)."""
    R, h = p["radius_m"], p["height_m"]
    e = 0.12 * R
    bottom = [(0, 0.6 * e), (R - e, 0), (R - 0.4 * e, 0), (R, 0.6 * e)]
    top = [(R, h - 1.5 * e), (R - 0.5 * e, h - 0.3 * e), (R - 0.5 * e, h), (R - 0.9 * e, h), (R - 0.9 * e, h - 0.5 * e)]
    visual = _revolve([*bottom, *top, (0, h - 0.5 * e)])
    return _finish(visual, [visual.convex_hull])


@register("box", "length_m width_m height_m")
def build_box(p: dict[str, float]) -> Built:
    """Lidded box: length_m along x (front to back), width_m along y, height_m tall; the lid
    overhangs the base a little so it reads as a box, not a brick."""
    L, W, H = p["length_m"], p["width_m"], p["height_m"]
    e = 0.03 * min(L, W)
    base = trimesh.creation.box(bounds=[(e - L / 2, e - W / 2, 0), (L / 2 - e, W / 2 - e, 0.8 * H)])
    visual = _union([base, trimesh.creation.box(bounds=[(-L / 2, -W / 2, 0.75 * H), (L / 2, W / 2, H)])])
    return _finish(visual, [visual.convex_hull])


@register("book", "cover_length_m cover_width_m thickness_m", "thickness_m*2 <= cover_width_m")
def build_book(p: dict[str, float]) -> Built:
    """Closed book lying flat: two covers, a page block inset on three sides and a rounded spine
    on +x; cover_width_m along x, cover_length_m along y, thickness_m tall."""
    L, W, t = p["cover_length_m"], p["cover_width_m"], p["thickness_m"]
    c, inset, xs = min(max(0.1 * t, 0.0015), 0.003), 0.015 * W, W / 2 - t / 4  # cover, page inset, spine axis
    slabs = [(-W / 2, L / 2, 0, c), (-W / 2, L / 2, t - c, t), (inset - W / 2, L / 2 - inset, c / 2, t - c / 2)]
    boxes = [trimesh.creation.box(bounds=[(x0, -y, z0), (xs, y, z1)]) for x0, y, z0, z1 in slabs]
    spine = trimesh.creation.cylinder(radius=t / 2, height=L, sections=16)
    spine.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, (1, 0, 0)))
    spine.apply_scale((0.5, 1.0, 1.0))
    spine.apply_translation((xs, 0, t / 2))
    visual = _union([*boxes, spine])
    return _finish(visual, [visual.convex_hull])


@register("apple", "radius_m squash stem_length_m", "stem_length_m*1 <= radius_m")
def build_apple(p: dict[str, float]) -> Built:
    """Revolved sphere of radius_m squashed vertically by `squash`, with dimples at both poles
    and a thin stem of stem_length_m rising from the top dimple."""
    R, q, stem = p["radius_m"], p["squash"], p["stem_length_m"]
    phi = np.linspace(0, math.pi, 25)
    r, z = R * np.sin(phi), R * q * (1 - np.cos(phi))
    z += np.where(phi < math.pi / 2, 0.2, -0.3) * R * q * np.exp(-((r / (0.35 * R)) ** 2))  # pole dimples
    top = z[-1]
    stalk = trimesh.creation.cylinder(radius=0.06 * R, segment=[(0, 0, top - 0.1 * R), (0, 0, top + stem)], sections=8)
    visual = _union([_revolve(np.column_stack([r, z])), stalk])
    return _finish(visual, [visual.convex_hull])


@register("banana", "length_m radius_m bend_deg", "radius_m*5 <= length_m", "bend_deg*1 <= 150")
def build_banana(p: dict[str, float]) -> Built:
    """Ridged tube along a planar arc of length_m turning through bend_deg, radius_m at its
    thickest, tapering to a nub at the tip and a stalk at the stem end (+x); lies on its side.
    Four hulls along the curve, since one would fill the inside of the bend."""
    L, R, bend = p["length_m"], p["radius_m"], math.radians(p["bend_deg"])
    a = np.linspace(-bend / 2, bend / 2, 29)
    s = (a - a[0]) / bend  # 0 at the tip, 1 at the stem
    flesh = np.sin(math.pi * np.minimum(s / 0.88, 1.0)) ** 0.5
    radii = R * np.maximum(flesh, np.where(s > 0.5, 0.28, 0.15))  # a thin stalk on the last 12 %, a nub at the tip
    # centreline at the local radius: the underside lies flat along the whole arc, so it does not rock
    path = np.column_stack([L / bend * np.sin(a), L / bend * np.cos(a), radii])
    rings = _tube_rings(path, radii, np.array([0.0, 0.0, 1.0]), 16, ridges=5)
    parts = [_hull(rings[i : i + 8].reshape(-1, 3)) for i in (0, 7, 14, 21)]
    return _finish(_tube(rings, path), parts)


@register(
    "vase", "radius_m height_m neck_radius_m mouth_radius_m wall_m base_m",
    "neck_radius_m*1 <= radius_m", "mouth_radius_m*1 <= radius_m",
    "wall_m*2.5 <= neck_radius_m", "base_m*4 <= height_m",
)
def build_vase(p: dict[str, float]) -> Built:
    """Hollow revolved vase open at the top: foot, belly of radius_m, neck of neck_radius_m,
    flared mouth of mouth_radius_m at a rounded lip height_m high; wall_m thick walls, base_m
    thick bottom. One hull: the mouth is too narrow to put things in."""
    R, h, w, b = p["radius_m"], p["height_m"], p["wall_m"], p["base_m"]
    knots_z = np.array([0.0, 0.35 * h, 0.78 * h, h - w / 2])
    knots_r = np.array([0.6 * R, R, p["neck_radius_m"], p["mouth_radius_m"]])
    z = np.concatenate([np.linspace(z0, z1, 7)[:-1] for z0, z1 in zip(knots_z[:-1], knots_z[1:])] + [knots_z[-1:]])
    k = np.clip(np.searchsorted(knots_z, z, side="right") - 1, 0, 2)
    u = (1 - np.cos(math.pi * (z - knots_z[k]) / (knots_z[k + 1] - knots_z[k]))) / 2
    r = knots_r[k] + (knots_r[k + 1] - knots_r[k]) * u  # cosine blend between knots: smooth, no overshoot
    inner = [(ri - w, zi) for ri, zi in zip(r[-2::-1], z[-2::-1]) if zi > b] + [(float(np.interp(b, z, r)) - w, b)]
    visual = _revolve([(0, 0), *zip(r[:-1], z[:-1]), *_lip(r[-1], r[-1] - w, h), *inner, (0, b)])
    return _finish(visual, [visual.convex_hull])


_TEDDY = (  # (centre, radii) as fractions of the sitting height; the first five form the body hull
    ((0.00, 0.00, 0.26), (0.19, 0.20, 0.26)),  # body
    ((0.07, 0.20, 0.36), (0.08, 0.07, 0.14)),  # arms
    ((0.07, -0.20, 0.36), (0.08, 0.07, 0.14)),
    ((0.15, 0.12, 0.07), (0.16, 0.08, 0.07)),  # legs, pointing forward
    ((0.15, -0.12, 0.07), (0.16, 0.08, 0.07)),
    ((0.02, 0.00, 0.68), (0.17, 0.18, 0.17)),  # head
    ((0.00, 0.13, 0.82), (0.05, 0.07, 0.07)),  # ears
    ((0.00, -0.13, 0.82), (0.05, 0.07, 0.07)),
    ((0.17, 0.00, 0.64), (0.07, 0.08, 0.06)),  # muzzle, on the face side
)


@register("teddy_bear", "height_m")
def build_teddy_bear(p: dict[str, float]) -> Built:
    """Sitting teddy bear height_m tall: ellipsoid body, head, ears, muzzle, arms and
    forward-pointing legs, face on +x. Two hulls: body with limbs, head with ears and muzzle."""
    blobs = [trimesh.creation.icosphere(subdivisions=2) for _ in _TEDDY]
    for blob, (centre, radii) in zip(blobs, _TEDDY):
        blob.apply_scale(radii)
        blob.apply_translation(centre)
    parts = [_hull(np.vstack([m.vertices for m in group])) for group in (blobs[:5], blobs[5:])]
    return _finish(_union(blobs), parts, height=p["height_m"])


@register("toy_block", "size_m bevel_m", "bevel_m*4 <= size_m")
def build_toy_block(p: dict[str, float]) -> Built:
    """Cube of edge size_m with chamfered edges bevel_m wide; convex, so visual = collision."""
    s, e = p["size_m"], p["bevel_m"]
    corners = np.array(np.meshgrid([-0.5, 0.5], [-0.5, 0.5], [-0.5, 0.5])).reshape(3, -1).T
    visual = _hull(np.vstack([corners * (s - 2 * e * (1 - np.eye(3)[i])) for i in range(3)]))
    return _finish(visual, [visual.copy()])
