"""Geometry helpers the builders share: revolved profiles, tubes, extruded outlines, rounded
slabs, convex wall parts for open containers, and the final move into the object frame.

Every helper returns a closed, outward-facing trimesh in metres; nothing here draws random
numbers.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any, Sequence

import manifold3d
import numpy as np
import trimesh

from ..scene import signed_volume
from .registry import Built

SEGMENTS = 32  # around revolved shapes: smooth at 960x540, cheap for a CPU rasteriser
WALL_PARTS = 12  # convex wedges around a rim; a multiple of 4 keeps the +-x/+-y extremes exact
X, Y, Z = np.eye(3)


# Builders make hundreds of small meshes per scene. trimesh's constructors and transforms
# process, validate and re-cache every one (a cylinder cost 1 ms); the helpers below build
# vertex and face arrays directly and wrap them unprocessed.
def _mesh(vertices: np.ndarray, faces: np.ndarray) -> trimesh.Trimesh:
    return trimesh.Trimesh(vertices, faces, process=False)


def outward(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The mesh with its faces turned outward (a closed mesh with negative volume is inside out)."""
    return _mesh(*_outward(np.asarray(mesh.vertices), np.asarray(mesh.faces)))


def _outward(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if signed_volume(vertices, faces) < 0:
        return vertices, np.ascontiguousarray(faces[:, ::-1])
    return vertices, faces


def revolve(profile: Any, sections: int = SEGMENTS) -> trimesh.Trimesh:
    """Revolve an (r, z) profile about +z; both ends on the axis give a closed solid.

    Every profile point becomes a ring of `sections` vertices, and each band between two
    rings two triangles per section; a ring on the axis collapses onto one pole vertex, and
    the triangles that collapse with it are dropped."""
    rz = np.asarray(profile, dtype=float)
    keep = np.ones(len(rz), dtype=bool)
    keep[1:] = (rz[1:] != rz[:-1]).any(axis=1)  # a repeated point adds an empty band
    rz = rz[keep]
    cos, sin = _ring(sections)
    grid = np.empty((len(rz), sections, 3))
    grid[..., 0] = rz[:, :1] * cos
    grid[..., 1] = rz[:, :1] * sin
    grid[..., 2] = rz[:, 1:]
    index = np.arange(grid.shape[0] * sections).reshape(-1, sections)
    pole = np.abs(rz[:, 0]) < 1e-12
    index[pole] = index[pole][:, :1]
    a, b = index[:-1], index[1:]
    d, c = np.concatenate([a[:, 1:], a[:, :1]], axis=1), np.concatenate([b[:, 1:], b[:, :1]], axis=1)
    faces = np.concatenate([np.stack([a, c, d], -1).reshape(-1, 3), np.stack([a, b, c], -1).reshape(-1, 3)])
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 2] != faces[:, 0])]
    used = np.zeros(index.size, dtype=bool)
    used[faces.ravel()] = True
    remap = np.cumsum(used) - 1
    return _mesh(*_outward(grid.reshape(-1, 3)[used], remap[faces]))


@functools.lru_cache(maxsize=None)
def _ring(sections: int) -> tuple[np.ndarray, np.ndarray]:
    theta = np.linspace(0, 2 * math.pi, sections, endpoint=False)
    return np.cos(theta), np.sin(theta)


def arc(cr: float, cz: float, radius: float, a0: float, a1: float, n: int = 7) -> list[tuple[float, float]]:
    """Points on a circular arc in the (r, z) plane, for rounded rims and edges."""
    return [(cr + radius * math.cos(a), cz + radius * math.sin(a)) for a in np.linspace(a0, a1, n)]


def lip(r_out: float, r_in: float, top: float) -> list[tuple[float, float]]:
    """A rounded rim from the outer to the inner wall whose crest is exactly at `top`."""
    half = (r_out - r_in) / 2
    return arc(r_in + half, top - half, half, 0.0, math.pi)


def union(meshes: Sequence[trimesh.Trimesh]) -> trimesh.Trimesh:
    return _trimesh(manifold3d.Manifold.batch_boolean([_solid(m) for m in meshes], manifold3d.OpType.Add))


def difference(body: trimesh.Trimesh, *cutters: trimesh.Trimesh) -> trimesh.Trimesh:
    cut = manifold3d.Manifold.batch_boolean([_solid(m) for m in cutters], manifold3d.OpType.Add)
    return _trimesh(_solid(body) - cut)


# Booleans call manifold3d directly: trimesh's wrapper first proves every input a volume with
# its mass properties (about half of all shape-building time); manifold checks the topology in
# C++, and a positive volume says the faces point outward.
def _solid(mesh: trimesh.Trimesh) -> manifold3d.Manifold:
    """The mesh as a manifold solid; for the rare parameter draw where a thin extruded outline
    folds over itself (not a closed volume), the repaired mesh or else its convex hull."""
    solid = _manifold(mesh)
    if solid.status() == manifold3d.Error.NoError and solid.volume() > 0:
        return solid
    repaired = mesh.copy()
    trimesh.repair.fix_winding(repaired)
    trimesh.repair.fix_normals(repaired)
    return _manifold(repaired if repaired.is_volume else mesh.convex_hull)


def _manifold(mesh: trimesh.Trimesh) -> manifold3d.Manifold:
    return manifold3d.Manifold(manifold3d.Mesh(vert_properties=np.asarray(mesh.vertices, dtype=np.float32),
                                               tri_verts=np.asarray(mesh.faces, dtype=np.uint32)))


def _trimesh(solid: manifold3d.Manifold) -> trimesh.Trimesh:
    mesh = solid.to_mesh()
    return _mesh(mesh.vert_properties.astype(np.float64), mesh.tri_verts.astype(np.int64))


def hull(points: Any) -> trimesh.Trimesh:
    """Convex hull as a closed, outward mesh of the hull's own vertices. manifold3d's QuickHull:
    builders make hundreds of small hulls per scene, and it is six times quicker than Qhull
    through scipy plus the orientation fix-up that needs."""
    pts = np.asarray(points, dtype=float)
    solid = manifold3d.Manifold.hull_points(pts)
    if solid.volume() <= 0:  # flat or degenerate input has no volume; trimesh's hull of it, as ever
        return trimesh.convex.convex_hull(pts)
    mesh = solid.to_mesh64()
    return _mesh(np.array(mesh.vert_properties[:, :3]), np.array(mesh.tri_verts, dtype=np.int64))


def hull_of(*meshes: trimesh.Trimesh) -> trimesh.Trimesh:
    return hull(np.vstack([m.vertices for m in meshes]))


def box(lo: Sequence[float], hi: Sequence[float]) -> trimesh.Trimesh:
    """Axis-aligned box between two opposite corners (in either order)."""
    a, b = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    vertices, faces = _unit_box()
    return _mesh(lo + vertices * (hi - lo), faces.copy())


@functools.lru_cache(maxsize=1)
def _unit_box() -> tuple[np.ndarray, np.ndarray]:
    unit = trimesh.creation.box()  # centred on the origin
    return np.array(unit.vertices) + 0.5, np.array(unit.faces)


def cylinder(radius: float, p0: Sequence[float], p1: Sequence[float], sections: int = 16) -> trimesh.Trimesh:
    """A round rod from p0 to p1."""
    p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
    axis = p1 - p0
    half = float(np.linalg.norm(axis)) / 2
    rod = revolve([(0.0, -half), (radius, -half), (radius, half), (0.0, half)], sections)
    frame = trimesh.geometry.align_vectors((0.0, 0.0, 1.0), axis)
    return _mesh(rod.vertices @ frame[:3, :3].T + (p0 + p1) / 2, rod.faces)


def sphere(subdivisions: int, radius: float = 1.0) -> trimesh.Trimesh:
    """Icosphere about the origin (subdividing is the expensive part, so it happens once)."""
    vertices, faces = _unit_sphere(subdivisions)
    return _mesh(vertices * radius, faces.copy())


@functools.lru_cache(maxsize=None)
def _unit_sphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    unit = trimesh.creation.icosphere(subdivisions=subdivisions)
    return np.array(unit.vertices), np.array(unit.faces)


def ellipsoid(centre: Sequence[float], radii: Sequence[float], subdivisions: int = 2) -> trimesh.Trimesh:
    vertices, faces = _unit_sphere(subdivisions)
    return _mesh(vertices * np.asarray(radii, float) + np.asarray(centre, float), faces.copy())


def circle(cx: float, cy: float, radius: float, n: int = 16) -> np.ndarray:
    """(n, 2) counter-clockwise points of a circle."""
    a = np.linspace(0, 2 * math.pi, n, endpoint=False)
    return np.column_stack([cx + radius * np.cos(a), cy + radius * np.sin(a)])


def rect(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    """(4, 2) counter-clockwise corners of an axis-aligned rectangle."""
    return np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1)], dtype=float)


def rounded_rect(half_x: float, half_y: float, corner: float, n: int = 6) -> np.ndarray:
    """(4n, 2) outline of a rectangle centred on the origin with corners rounded by `corner`,
    n points per quarter circle."""
    a = np.linspace(0, math.pi / 2, n)
    quarter = np.column_stack([np.cos(a), np.sin(a)]) * corner
    return np.vstack([quarter * (sx, sy) + (sx * (half_x - corner), sy * (half_y - corner))
                      for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))])


def rounded_slab(half_x: float, half_y: float, z0: float, z1: float, corner: float, n: int = 6) -> trimesh.Trimesh:
    """Convex slab with vertical edges rounded by `corner` (phones, boards, trays)."""
    flat = rounded_rect(half_x, half_y, corner, n)
    return hull(np.vstack([np.column_stack([flat, np.full(len(flat), z)]) for z in (z0, z1)]))


def rounded_block(lo: Sequence[float], hi: Sequence[float], radius: float) -> trimesh.Trimesh:
    """Convex box with every edge rounded by `radius` (at most half its thinnest side, so the
    box keeps its size): the hull of eight corner spheres."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    radius = min(radius, 0.499 * float(np.min(hi - lo)))
    ball = sphere(1, radius).vertices
    lo, hi = lo + radius, hi - radius
    corners = np.array(np.meshgrid(*zip(lo, hi))).reshape(3, -1).T
    return hull(np.vstack([ball + c for c in corners]))


def extrude(contours: Sequence[Any], z0: float, z1: float, round_m: float = 0.0) -> trimesh.Trimesh:
    """Extrude 2-D outlines (counter-clockwise; clockwise ones are holes) from z0 to z1, with
    corners rounded by round_m (outlines are shrunk then grown back, so the size is kept)."""
    section = manifold3d.CrossSection([np.asarray(c, dtype=float) for c in contours])
    if round_m > 0:
        section = section.offset(-round_m, circular_segments=24).offset(round_m, circular_segments=24)
    return from_manifold(section.extrude(z1 - z0).translate((0.0, 0.0, z0)))


def to_manifold(mesh: trimesh.Trimesh) -> manifold3d.Manifold:
    return manifold3d.Manifold(
        manifold3d.Mesh64(
            vert_properties=np.ascontiguousarray(mesh.vertices, dtype=np.float64),
            tri_verts=np.ascontiguousarray(mesh.faces, dtype=np.uint64),
        )
    )


def from_manifold(solid: manifold3d.Manifold) -> trimesh.Trimesh:
    mesh = solid.to_mesh64()
    # Copies: the arrays manifold hands out are read-only views of its own memory.
    return outward(_mesh(np.array(mesh.vert_properties[:, :3]), np.array(mesh.tri_verts, dtype=np.int64)))


def cut_below(mesh: trimesh.Trimesh, z: float) -> trimesh.Trimesh:
    """The mesh with everything below height z cut away: a flat patch to rest on."""
    return from_manifold(to_manifold(mesh).trim_by_plane((0.0, 0.0, 1.0), z))


def piece_hulls(mesh: trimesh.Trimesh, axis: int, cuts: Sequence[float]) -> list[trimesh.Trimesh]:
    """Convex hulls of the slices of `mesh` between planes across `axis` at `cuts`: together they
    cover the mesh exactly, and each is as tight as the slice is convex (long, bent things)."""
    solid, normal, out = to_manifold(mesh), np.eye(3)[axis], []
    edges = [-math.inf, *sorted(cuts), math.inf]
    for lo, hi in zip(edges[:-1], edges[1:]):
        piece = solid
        if lo > -math.inf:
            piece = piece.trim_by_plane(tuple(normal), lo)
        if hi < math.inf:
            piece = piece.trim_by_plane(tuple(-normal), -hi)
        if not piece.is_empty() and piece.volume() > 1e-12:
            out.append(hull(from_manifold(piece).vertices))
    return out


def rotated(
    mesh: trimesh.Trimesh, angle: float, axis: Sequence[float], point: Sequence[float] = (0, 0, 0)
) -> trimesh.Trimesh:
    """A copy turned by `angle` (radians, right-handed) about the line through `point` along `axis`."""
    m = trimesh.transformations.rotation_matrix(angle, axis, point)
    return _mesh(mesh.vertices @ m[:3, :3].T + m[:3, 3], mesh.faces.copy())


def moved(mesh: trimesh.Trimesh, offset: Sequence[float]) -> trimesh.Trimesh:
    """A copy shifted by `offset`."""
    return _mesh(mesh.vertices + np.asarray(offset, dtype=float), mesh.faces.copy())


def container_parts(outer: np.ndarray, inner: np.ndarray, base_r: float, base_z: float, bands: int = 1) -> list:
    """A base slab plus WALL_PARTS hulls of wall wedges per height band, so the cavity stays open
    for things resting inside. A curved wall needs bands: one hull per wedge would fill the
    cavity up to the chord of the profile."""
    parts = [cylinder(base_r, [0, 0, 0], [0, 0, base_z], WALL_PARTS)]
    angles = np.linspace(0, 2 * math.pi, WALL_PARTS + 1)
    cuts = np.linspace(0, len(outer) - 1, bands + 1).round().astype(int)
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        rz = np.vstack([outer[lo : hi + 1], inner[lo : hi + 1]])
        for a0, a1 in zip(angles[:-1], angles[1:]):
            wedge = [np.column_stack([rz[:, 0] * math.cos(a), rz[:, 0] * math.sin(a), rz[:, 1]]) for a in (a0, a1)]
            parts.append(hull(np.vstack(wedge)))
    return parts


def vessel(
    z: np.ndarray,
    r_out: np.ndarray,
    r_in: np.ndarray,
    base: float,
    bands: int = 1,
    sections: int = SEGMENTS,
    inner_every: int = 1,
) -> tuple[trimesh.Trimesh, list]:
    """An open revolved container and its convex parts. The outer wall has radius r_out at
    heights z (z[0] = 0 the foot, z[-1] the rim's crest), the inner wall r_in at the same
    heights above the floor at `base`; a rounded lip joins them. Parts: a floor disc and
    WALL_PARTS wedges per band, so the cavity stays open. A straight inner wall needs only
    every `inner_every`-th height."""
    z, r_out, r_in = (np.asarray(a, dtype=float) for a in (z, r_out, r_in))
    rim = lip(r_out[-1], r_in[-1], z[-1])
    keep = (z > base) & (z < rim[0][1])
    inner = list(zip(r_in[keep][::-inner_every], z[keep][::-inner_every]))
    below = z < rim[0][1]
    profile = [
        (0.0, 0.0),
        *zip(r_out[below], z[below]),
        *rim,
        *inner,
        (float(np.interp(base, z, r_in)), base),
        (0.0, base),
    ]
    parts = container_parts(
        np.column_stack([r_out, z]), np.column_stack([r_in, np.maximum(z, base)]), r_out[0], base, bands
    )
    return revolve(profile, sections), parts


def blend(z: np.ndarray, knots_z: Sequence[float], knots_r: Sequence[float]) -> np.ndarray:
    """Radius at heights z, cosine-blended between (knot_z, knot_r) pairs: smooth, no overshoot."""
    kz, kr = np.asarray(knots_z, dtype=float), np.asarray(knots_r, dtype=float)
    k = np.clip(np.searchsorted(kz, z, side="right") - 1, 0, len(kz) - 2)
    u = (1 - np.cos(math.pi * np.clip((z - kz[k]) / (kz[k + 1] - kz[k]), 0, 1))) / 2
    return kr[k] + (kr[k + 1] - kr[k]) * u


def tray_parts(bottom: tuple[float, float], top: tuple[float, float], wall: float, base: float, height: float) -> list:
    """A floor slab plus four convex wall slabs of an open rectangular container whose outer
    half extents (x, y) grow from `bottom` at z=0 to `top` at `height`; the cavity stays open."""
    parts = [box((-bottom[0], -bottom[1], 0), (bottom[0], bottom[1], base))]
    for axis in (0, 1):
        for sign in (1.0, -1.0):
            points = []
            for half, z in ((bottom, 0.0), (top, height)):
                for depth in (half[axis], half[axis] - wall):
                    for span in (-half[1 - axis], half[1 - axis]):
                        p = np.array([0.0, 0.0, z])
                        p[axis], p[1 - axis] = sign * depth, span
                        points.append(p)
            parts.append(hull(points))
    return parts


def tube_rings(path: np.ndarray, radii: np.ndarray, up: np.ndarray, around: int, ridges: int = 0) -> np.ndarray:
    """(n, around, 3) circles, optionally ridged, swept along a path that runs across `up`; each
    ring spans `up` and the horizontal normal, so its lowest point is exactly one radius below."""
    side = np.cross(up, np.gradient(path, axis=0))
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    phi = np.linspace(0, 2 * math.pi, around, endpoint=False)
    r = radii[:, None] * (1 + 0.06 * np.cos(ridges * phi) * bool(ridges))[None, :]
    offsets = np.cos(phi)[None, :, None] * side[:, None, :] + np.sin(phi)[None, :, None] * up
    return path[:, None, :] + r[:, :, None] * offsets


def tube(rings: np.ndarray, path: np.ndarray) -> trimesh.Trimesh:
    """Closed tube through the rings, with flat caps fanned from the path's end points."""
    n, m = rings.shape[:2]
    i, j = np.meshgrid(np.arange(n - 1), np.arange(m), indexing="ij")
    a, b = i * m + j, i * m + (j + 1) % m
    sides = np.vstack([np.stack([a, a + m, b + m], -1).reshape(-1, 3), np.stack([a, b + m, b], -1).reshape(-1, 3)])
    j, last = np.arange(m), (n - 1) * m
    start = np.column_stack([np.full(m, n * m), j, (j + 1) % m])
    end = np.column_stack([np.full(m, n * m + 1), last + (j + 1) % m, last + j])
    return outward(_mesh(np.vstack([rings.reshape(-1, 3), path[[0, -1]]]), np.vstack([sides, start, end])))


def rod(path: Any, radius: float, up: Sequence[float] = (0.0, 1.0, 0.0), around: int = 10) -> trimesh.Trimesh:
    """A round tube of constant radius along a polyline whose points all lie across `up`."""
    path = np.asarray(path, dtype=float)
    return tube(tube_rings(path, np.full(len(path), radius), np.asarray(up, dtype=float), around), path)


def finish(visual: trimesh.Trimesh, parts: list, centre: bool = True, height: float | None = None) -> Built:
    """Move into the object frame: lowest point on z=0, footprint centred on the origin (unless
    the builder already centred the main body), optionally scaled uniformly to an exact height."""
    lo, hi = visual.vertices.min(0), visual.vertices.max(0)
    shift = -np.array([(lo[0] + hi[0]) / 2 * centre, (lo[1] + hi[1]) / 2 * centre, lo[2]])
    scale = 1.0 if height is None else height / (hi[2] - lo[2])
    visual, *parts = (FinalMesh((np.asarray(m.vertices) + shift) * scale, np.asarray(m.faces)) for m in (visual, *parts))
    return visual, parts


@dataclass(frozen=True)
class FinalMesh:
    """A builder's finished mesh: only its arrays, which is all that assets read from it. A
    trimesh.Trimesh for each (a visual mesh and a dozen parts an object) cost 40 us apiece to
    set up, for caches nobody used."""

    vertices: np.ndarray  # (N, 3) float, metres, object frame
    faces: np.ndarray  # (M, 3) int
