"""Open and closed containers: box, vase, basket, tray, plant pot, pen holder, tissue box."""

from __future__ import annotations

import math

import manifold3d
import numpy as np
import trimesh

from . import geometry as g
from .registry import Built, register


@register("box", "length_m width_m height_m")
def build_box(p: dict[str, float]) -> Built:
    """Lidded box: length_m along x (front to back), width_m along y, height_m tall; the lid
    overhangs the base a little so it reads as a box, not a brick."""
    L, W, H = p["length_m"], p["width_m"], p["height_m"]
    e = 0.03 * min(L, W)
    base = g.box((e - L / 2, e - W / 2, 0), (L / 2 - e, W / 2 - e, 0.8 * H))
    visual = g.union([base, g.box((-L / 2, -W / 2, 0.75 * H), (L / 2, W / 2, H))])
    return g.finish(visual, [g.hull(visual.vertices)])


@register(
    "vase",
    "radius_m height_m neck_radius_m mouth_radius_m wall_m base_m",
    "neck_radius_m*1 <= radius_m",
    "mouth_radius_m*1 <= radius_m",
    "wall_m*2.5 <= neck_radius_m",
    "base_m*4 <= height_m",
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
    visual = g.revolve([(0, 0), *zip(r[:-1], z[:-1]), *g.lip(r[-1], r[-1] - w, h), *inner, (0, b)])
    return g.finish(visual, [g.hull(visual.vertices)])


def _torus(radius: float, tube_r: float, z: float, sections: int = 32, around: int = 6) -> trimesh.Trimesh:
    ring = trimesh.creation.torus(
        major_radius=radius, minor_radius=tube_r, major_sections=sections, minor_sections=around
    )
    return g.moved(ring, (0, 0, z))


@register(
    "basket",
    "radius_m height_m wall_m",
    "wall_m*10 <= radius_m",
    "height_m*0.8 <= radius_m",
)
def build_basket(p: dict[str, float]) -> Built:
    """Round woven basket: an open tub flaring to radius_m at the rim, height_m tall, wall_m
    thick, its outside bumped in an over-under checkerboard and a thick rolled rim on top, so
    it reads as wicker. Hollow in physics: a floor and wall wedges."""
    R, h, w = p["radius_m"], p["height_m"], p["wall_m"]
    rb, t = 0.82 * R, 0.45 * w  # radius at the foot; how far the weave stands proud of the wall
    z = np.linspace(0, h, 25)
    r_out = rb + (R - rb) * z / h
    tub, parts = g.vessel(z, r_out, r_out - w, 1.2 * w, sections=48, inner_every=6)
    v = tub.vertices.copy()
    r, theta = np.hypot(v[:, 0], v[:, 1]), np.arctan2(v[:, 1], v[:, 0])
    outer = (r > np.interp(v[:, 2], z, r_out) - w / 2) & (v[:, 2] > 0.03 * h) & (v[:, 2] < h - w)
    weave = t * np.cos(12 * theta) * np.cos(2 * math.pi * v[:, 2] / (h / 5))  # over-under checkerboard
    v[outer, :2] *= (1 + weave[outer] / r[outer])[:, None]
    tub = trimesh.Trimesh(v, tub.faces)
    rim = _torus(R - w / 2, 0.75 * w, h - 0.75 * w, 32, 6)
    return g.finish(g.union([tub, rim]), parts)


def _rounded_rect_points(half_x: float, half_y: float, corner: float, z: float, n: int = 5) -> np.ndarray:
    flat = g.rounded_rect(half_x, half_y, corner, n)
    return np.column_stack([flat, np.full(len(flat), z)])


@register(
    "tray",
    "length_m width_m height_m wall_m",
    "width_m*1 <= length_m",
    "height_m*4 <= width_m",
    "wall_m*4 <= height_m",
)
def build_tray(p: dict[str, float]) -> Built:
    """Serving tray: a flat floor length_m by width_m (at the rim) with low walls height_m
    high, wall_m thick, flaring outwards, and a rounded rim. A support, and a shallow container."""
    L, W, h, w = p["length_m"], p["width_m"], p["height_m"], p["wall_m"]
    flare, corner, base = 0.6 * h, 0.12 * W, 0.8 * w
    outer = g.hull(
        np.vstack(
            [
                _rounded_rect_points(L / 2 - flare, W / 2 - flare, corner - flare / 2, 0),
                _rounded_rect_points(L / 2, W / 2, corner, h),
            ]
        )
    )
    inner = g.hull(
        np.vstack(
            [
                _rounded_rect_points(L / 2 - flare - w, W / 2 - flare - w, corner - flare / 2 - w, base),
                _rounded_rect_points(L / 2 - w, W / 2 - w, corner - w, h),
            ]
        )
    )
    visual = g.difference(outer, inner)
    return g.finish(visual, g.tray_parts((L / 2 - flare, W / 2 - flare), (L / 2, W / 2), w, base, h))


@register("plant_pot", "radius_m height_m wall_m", "wall_m*6 <= radius_m", "radius_m*0.8 <= height_m")
def build_plant_pot(p: dict[str, float]) -> Built:
    """Flower pot: a tapered open pot with a thick band at the rim (radius_m outside at the top),
    height_m tall and wall_m thick, standing on a narrower foot. Hollow in physics."""
    R, h, w = p["radius_m"], p["height_m"], p["wall_m"]
    band = 0.2 * h
    z = np.array([0.0, 0.02 * h, 0.3 * h, 0.6 * h, h - band - 0.004, h - band, h - band + 0.004, h - 0.5 * band, h])
    r_body = 0.70 * R + (0.9 * R - 0.70 * R) * z / (h - band)
    r_out = np.where(z < h - band, r_body, R)
    r_out[0] -= 0.003  # a small chamfer at the foot
    r_in = np.minimum(r_body, 0.9 * R) - w
    visual, parts = g.vessel(z, r_out, r_in, 1.4 * w, bands=2)
    return g.finish(visual, parts)


def _tissue_section(half: float) -> manifold3d.CrossSection:
    """A thin wavy sheet across y: the tissue's cross-section where it leaves the box."""
    y = np.linspace(-half, half, 17)
    x = 0.007 * np.sin(2 * math.pi * y / half) * np.cos(0.5 * math.pi * y / half)
    return manifold3d.CrossSection(
        [np.vstack([np.column_stack([x + 0.0012, y]), np.column_stack([x - 0.0012, y])[::-1]])]
    )


@register("tissue_box", "length_m width_m height_m", "width_m*1 <= length_m", "height_m*1 <= width_m")
def build_tissue_box(p: dict[str, float]) -> Built:
    """Tissue box: a block length_m (along y) by width_m (along x) by height_m with an oval
    opening on top and a tissue poking out of it. Two hulls: box and tissue."""
    L, W, H = p["length_m"], p["width_m"], p["height_m"]
    body = g.rounded_block((-W / 2, -L / 2, 0), (W / 2, L / 2, H), 0.006)
    a = np.linspace(0, 2 * math.pi, 24, endpoint=False)
    hole = g.extrude([np.column_stack([0.16 * W * np.cos(a), 0.32 * L * np.sin(a)])], H - 0.012, H + 0.01)
    tissue = g.from_manifold(
        _tissue_section(0.2 * L).extrude(0.06, n_divisions=6, twist_degrees=25, scale_top=(0.6, 0.5))
    )
    tissue = g.moved(tissue, (0, 0, H - 0.012))
    visual = g.union([g.difference(body, hole), tissue])
    return g.finish(visual, [g.hull(body.vertices), g.hull(tissue.vertices)])


_PENS = (0.0, 2.1, 4.2)  # directions (radians) the three pens lean towards


@register("pen_holder", "radius_m height_m wall_m pen_length_m", "wall_m*6 <= radius_m", "height_m*1.1 <= pen_length_m")
def build_pen_holder(p: dict[str, float]) -> Built:
    """Desk pen holder: an open cylinder radius_m by height_m with wall_m walls, holding three
    capped pens pen_length_m long that lean against the rim. Hollow wall parts plus one hull
    per pen; it has no free cavity."""
    R, h, w, lp = p["radius_m"], p["height_m"], p["wall_m"], p["pen_length_m"]
    z = np.linspace(0, h, 4)
    cup, parts = g.vessel(z, np.full(4, R), np.full(4, R - w), 1.5 * w)
    pens = []
    for direction in _PENS:
        foot_z = 1.5 * w + 0.004
        lean = math.atan2(1.25 * (R - w), h - foot_z)  # foot near one wall, resting on the opposite rim
        d = np.array([math.cos(direction) * math.sin(lean), math.sin(direction) * math.sin(lean), math.cos(lean)])
        foot = np.array([-0.3 * (R - w) * math.cos(direction), -0.3 * (R - w) * math.sin(direction), foot_z])
        body = g.cylinder(0.0045, foot, foot + 0.88 * lp * d, 10)
        cap = g.cylinder(0.005, foot + 0.72 * lp * d, foot + lp * d, 10)
        clip = g.box((-0.001, -0.0012, 0), (0.0065, 0.0012, 0.25 * lp))
        clip = g.moved(g.rotated(g.rotated(clip, lean, g.Y), direction, g.Z), foot + 0.74 * lp * d)
        pens.append(g.union([body, cap, clip]))
    return g.finish(g.union([cup, *pens]), parts + [g.hull(pen.vertices) for pen in pens])
