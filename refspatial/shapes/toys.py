"""Toys: teddy bear, toy block, toy car, ball, rubber duck."""

from __future__ import annotations

import functools
import math

import numpy as np
import trimesh

from . import geometry as g
from .registry import Built, register

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
    visual, parts = _teddy_unit()
    return g.finish(visual, list(parts), height=p["height_m"])


@functools.lru_cache(maxsize=1)
def _teddy_unit() -> tuple[trimesh.Trimesh, list[trimesh.Trimesh]]:
    """The bear before scaling: the same every time, and a union of eleven blobs is slow."""
    blobs = [g.ellipsoid(centre, radii) for centre, radii in _TEDDY]
    parts = [g.hull(np.vstack([m.vertices for m in group])) for group in (blobs[:5], blobs[5:])]
    return g.union(blobs), parts


@register("toy_block", "size_m bevel_m", "bevel_m*4 <= size_m")
def build_toy_block(p: dict[str, float]) -> Built:
    """Cube of edge size_m with chamfered edges bevel_m wide; convex, so visual = collision."""
    s, e = p["size_m"], p["bevel_m"]
    corners = np.array(np.meshgrid([-0.5, 0.5], [-0.5, 0.5], [-0.5, 0.5])).reshape(3, -1).T
    visual = g.hull(np.vstack([corners * (s - 2 * e * (1 - np.eye(3)[i])) for i in range(3)]))
    return g.finish(visual, [visual.copy()])


@register("toy_car", "length_m width_m height_m", "width_m*1.4 <= length_m", "height_m*0.8 <= width_m")
def build_toy_car(p: dict[str, float]) -> Built:
    """Toy car length_m long (bonnet towards +x), width_m wide and height_m tall: a rounded body
    with wheel arches, a cabin set back with window recesses, headlights and four wheels with
    hubs it stands on. Hulls: body, cabin and one per wheel."""
    L, W, H = p["length_m"], p["width_m"], p["height_m"]
    rw, ww = 0.135 * L, 0.2 * W  # wheel radius and width
    axles = [(sx * 0.31 * L, sy * (W / 2 - ww / 2 + 0.002)) for sx in (1, -1) for sy in (1, -1)]
    body = g.rounded_block((-L / 2, -W / 2, 0.5 * rw), (L / 2, W / 2, 0.58 * H), 0.12 * H)
    arches = [g.cylinder(1.15 * rw, (x, 0.5 * y, rw), (x, 1.5 * y, rw), 20) for x, y in axles]
    body = g.difference(body, *arches)
    cabin = g.hull(
        np.vstack(
            [
                g.box((-0.32 * L, -0.42 * W, 0.5 * H), (0.12 * L, 0.42 * W, 0.55 * H)).vertices,
                g.box((-0.24 * L, -0.36 * W, H - 0.01), (0.0, 0.36 * W, H)).vertices,
            ]
        )
    )
    windows = [g.box((-0.2 * L, s * 0.5 * W, 0.64 * H), (0.02 * L, s * 0.3 * W, 0.9 * H)) for s in (1, -1)]
    windows.append(g.box((0.04 * L, -0.3 * W, 0.63 * H), (0.2 * L, 0.3 * W, 0.88 * H)))
    cabin_cut = g.difference(
        cabin, *[g.rotated(wd, math.radians(-8), g.Y, (0.08 * L, 0, 0.6 * H)) for wd in windows[2:]], *windows[:2]
    )
    lights = [g.ellipsoid((L / 2 - 0.005, s * 0.3 * W, 0.45 * H), (0.005, 0.008, 0.005), 1) for s in (1, -1)]
    wheels = [g.cylinder(rw, (x, y - ww / 2, rw), (x, y + ww / 2, rw), 18) for x, y in axles]
    hubs = [g.cylinder(0.45 * rw, (x, y, rw), (x, y + math.copysign(ww / 2 + 0.001, y), rw), 12) for x, y in axles]
    visual = g.union([body, cabin_cut, *lights, *wheels, *hubs])
    return g.finish(visual, [g.hull(body.vertices), g.hull(cabin.vertices), *[g.hull(wh.vertices) for wh in wheels]])


def _seams(points: np.ndarray, radius: float, depth: float, width: float) -> np.ndarray:
    """Press grooves along three great circles (the seams of a basketball) into a sphere."""
    n = points / np.linalg.norm(points, axis=1, keepdims=True)
    d = np.min(np.abs(n @ np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]).T), axis=1)  # sine of distance to a seam
    return n * (radius - depth * np.exp(-((d / width) ** 2)))[:, None]


@register("ball", "radius_m")
def build_ball(p: dict[str, float]) -> Built:
    """Toy ball of radius_m with grooved seams along three great circles, and a small flat
    patch where it rests (a ball on a table is slightly squashed there). One hull."""
    visual, part = _unit_ball()
    visual, part = visual.copy(), part.copy()
    for mesh in (visual, part):
        mesh.apply_scale(p["radius_m"])
    return g.finish(visual, [part])


@functools.lru_cache(maxsize=1)
def _unit_ball() -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """The ball of radius 1: every feature scales with the radius, and the seams and the cut
    of a 5120-face sphere cost 30 ms a ball."""
    sphere = g.sphere(4)
    v = _seams(sphere.vertices, 1.0, 0.04, 0.05)
    ball = g.rotated(trimesh.Trimesh(v, sphere.faces), math.radians(30), (1, 1, 0))  # seams off the axes
    visual = g.cut_below(ball, -0.985)
    return visual, g.hull(visual.vertices)


_DUCK = (  # (centre, radii) as fractions of the length; body, head, beak, tail, wings, eyes
    ((0.00, 0.00, 0.27), (0.50, 0.37, 0.27)),
    ((0.20, 0.00, 0.68), (0.23, 0.22, 0.22)),
    ((0.45, 0.00, 0.63), (0.12, 0.10, 0.035)),
    ((-0.43, 0.00, 0.45), (0.12, 0.10, 0.10)),
    ((-0.02, 0.33, 0.38), (0.26, 0.06, 0.12)),
    ((-0.02, -0.33, 0.38), (0.26, 0.06, 0.12)),
    ((0.33, 0.12, 0.76), (0.035, 0.035, 0.035)),
    ((0.33, -0.12, 0.76), (0.035, 0.035, 0.035)),
)


@register("rubber_duck", "length_m")
def build_rubber_duck(p: dict[str, float]) -> Built:
    """Rubber duck length_m from tail to beak (+x): an egg-shaped body cut flat underneath, a
    round head, a flat beak, a raised tail, wings and eyes. Two hulls: body, head with beak."""
    L = p["length_m"]
    blobs = [g.ellipsoid(np.array(c) * L, np.array(r) * L, 2 if k < 2 else 1) for k, (c, r) in enumerate(_DUCK)]
    blobs[3] = g.rotated(blobs[3], math.radians(-35), g.Y, np.array(_DUCK[3][0]) * L)
    duck = g.difference(g.union(blobs), g.box((-L, -L, -L), (L, L, 0.06 * L)))
    v = duck.vertices
    parts = [g.hull(v[v[:, 2] < 0.52 * L]), g.hull(v[(v[:, 2] > 0.42 * L) & (v[:, 0] > -0.05 * L)])]
    return g.finish(duck, parts)
