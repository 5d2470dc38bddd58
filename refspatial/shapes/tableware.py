"""Dining and drinking: mug, cup, bowl, plate, wine glass, fork, spoon, knife."""

from __future__ import annotations

import math

import numpy as np
import trimesh

from . import geometry as g
from .registry import Built, register


@register(
    "mug",
    "radius_m height_m wall_m base_m handle_reach_m handle_radius_m",
    "wall_m*3 <= radius_m",
    "base_m*4 <= height_m",
    "handle_radius_m*7 <= height_m",
    "handle_radius_m*2 <= handle_reach_m",
)
def build_mug(p: dict[str, float]) -> Built:
    """Hollow cylinder (radius_m, height_m, wall_m, base_m) with a rounded rim and a D-shaped
    handle of round section on +x (handle_reach_m out of the wall, handle_radius_m thick).
    The body, not the footprint, is centred on the origin."""
    r, h, w, b = p["radius_m"], p["height_m"], p["wall_m"], p["base_m"]
    body = g.revolve([(0, 0), (r, 0), *g.lip(r, r - w, h), (r - w, b), (0, b)])
    t = np.linspace(0, math.pi, 17)
    path = np.column_stack([r - w / 2 + (p["handle_reach_m"] + w / 2) * np.sin(t), 0 * t, h * (0.55 + 0.3 * np.cos(t))])
    handle = g.tube(g.tube_rings(path, np.full(len(t), p["handle_radius_m"]), np.array([0.0, 1.0, 0.0]), 12), path)
    walls = g.container_parts(np.array([(r, 0), (r, h)]), np.array([(r - w, b), (r - w, h)]), r, b)
    return g.finish(g.union([body, handle]), walls + [g.hull(handle.vertices)], centre=False)


@register(
    "cup",
    "radius_bottom_m radius_top_m height_m wall_m base_m",
    "radius_bottom_m*1 <= radius_top_m",
    "wall_m*3 <= radius_bottom_m",
    "base_m*4 <= height_m",
)
def build_cup(p: dict[str, float]) -> Built:
    """Hollow tapered tumbler: radius_bottom_m at the foot, radius_top_m at the rounded rim,
    height_m tall, wall_m thick walls, base_m thick bottom."""
    rb, rt, h, w, b = p["radius_bottom_m"], p["radius_top_m"], p["height_m"], p["wall_m"], p["base_m"]
    rib = rb - w + (rt - rb) * b / h  # inner wall radius at the top of the base
    visual = g.revolve([(0, 0), (rb, 0), *g.lip(rt, rt - w, h), (rib, b), (0, b)])
    return g.finish(visual, g.container_parts(np.array([(rb, 0), (rt, h)]), np.array([(rib, b), (rt - w, h)]), rb, b))


_BOWL_SWEEP = 0.45 * math.pi  # how far the wall turns, from flat at the foot to near-vertical at the rim


@register(
    "bowl",
    "radius_m base_radius_m height_m wall_m base_m",
    "base_radius_m*1.2 <= radius_m",
    "wall_m*3 <= base_radius_m",
    "base_m*3 <= height_m",
)
def build_bowl(p: dict[str, float]) -> Built:
    """Hollow revolved bowl: flat bottom of base_radius_m, a wall curving up to radius_m at a
    rounded rim height_m high, wall_m thick walls, base_m thick bottom. Walls in two bands."""
    R, rb, h, w, b = p["radius_m"], p["base_radius_m"], p["height_m"], p["wall_m"], p["base_m"]
    a = np.linspace(0, _BOWL_SWEEP, 11)
    s, c = np.sin(a) / math.sin(_BOWL_SWEEP), (1 - np.cos(a)) / (1 - math.cos(_BOWL_SWEEP))
    outer = np.column_stack([rb + (R - rb) * s, (h - w / 2) * c])
    inner = np.column_stack([rb - w + (R - rb) * s, b + (h - w / 2 - b) * c])  # up by the base, in by the wall
    visual = g.revolve([(0, 0), *outer, *g.lip(R, R - w, h)[1:-1], *inner[::-1], (0, b)])
    parts = g.container_parts(np.vstack([outer, [(R, h)]]), np.vstack([inner, [(R - w, h)]]), rb, b, bands=2)
    return g.finish(visual, parts)


@register(
    "plate", "radius_m rim_width_m height_m thickness_m", "rim_width_m*2 <= radius_m", "thickness_m*3.4 <= height_m"
)
def build_plate(p: dict[str, float]) -> Built:
    """Flat dish: a well of radius_m - rim_width_m and a rim sloping up to radius_m at height_m,
    thickness_m thick, with a rounded outer edge. Collision: a floor disc and rim wedges in two
    bands, so food put on a plate rests in the well, not on the rim's plane."""
    R, h, t = p["radius_m"], p["height_m"], p["thickness_m"]
    rw, k = R - p["rim_width_m"], 0.4 * h
    edge = g.arc(R - t / 2, h - t / 2, t / 2, -math.pi / 2, math.pi / 2)
    top = [(rw - 0.3 * t, k + t), (0.75 * rw - 0.3 * t, t), (0, t)]
    visual = g.revolve([(0, 0), (0.75 * rw, 0), (rw, k), *edge, *top])
    outer = np.array([(0.75 * rw, 0), (rw, k), (R, h)])
    inner = np.array([(0.75 * rw - 0.3 * t, t), (rw - 0.3 * t, k + t), (R - t, h)])
    return g.finish(visual, g.container_parts(outer, inner, 0.75 * rw, t, bands=2))


@register(
    "wine_glass",
    "radius_m height_m foot_radius_m stem_m wall_m",
    "wall_m*6 <= radius_m",
    "stem_m*2 <= height_m",
    "foot_radius_m*1 <= radius_m",
)
def build_wine_glass(p: dict[str, float]) -> Built:
    """Stemmed glass: a foot disc of foot_radius_m, a thin stem stem_m tall, and a tulip bowl
    (widest radius_m, closing in slightly to the rim) up to height_m, wall_m thick, open on top.
    Three hulls (foot, stem, bowl): nothing is meant to go inside a wine glass."""
    R, h, rf, stem, w = p["radius_m"], p["height_m"], p["foot_radius_m"], p["stem_m"], p["wall_m"]
    tf, rs = 0.004, 0.0035  # foot thickness and stem radius, as in most glasses
    cup_h = h - stem
    t = np.linspace(0, 1, 12)
    r_out = R * np.sin(np.minimum(t * 1.9, math.pi / 2 + 0.25 * t)) ** 0.8  # round belly, rim slightly in
    z_out = stem + cup_h * t
    r_out[0] = rs
    outer = [
        (0, 0),
        (rf, 0),
        (rf, 0.6 * tf),
        (rf - 0.004, tf),
        (1.6 * rs, tf + 0.004),
        (rs, tf + 0.01),
        *zip(r_out[:-1], z_out[:-1]),
    ]
    inner = list(zip(np.maximum(r_out[:-1] - w, 0.0)[::-1], z_out[:-1][::-1] + w))
    visual = g.revolve(
        [*outer, *g.lip(r_out[-1], r_out[-1] - w, h), *[q for q in inner if q[0] > 1.2 * w], (0, stem + 2 * w)]
    )
    parts = [g.cylinder(rf, (0, 0, 0), (0, 0, tf), 16), g.cylinder(1.6 * rs, (0, 0, tf), (0, 0, stem), 8)]
    parts.append(g.hull(visual.vertices[visual.vertices[:, 2] >= stem]))
    return g.finish(visual, parts)


def _cutlery(outline: list, tines: int, length: float, width: float, thickness: float) -> trimesh.Trimesh:
    """A flat utensil: `outline` as (x fraction of length, half-width fraction of width) pairs,
    mirrored about y=0, plus `tines` prongs over the last fifth; extruded `thickness` tall."""
    xs, hw = (np.array(outline) * (length, width)).T
    contours = [np.vstack([np.column_stack([xs, -hw]), np.column_stack([xs, hw])[::-1]])]
    pitch = width / max(tines, 1)
    for k in range(tines):
        y = (k - (tines - 1) / 2) * pitch
        contours.append(g.rect(0.77 * length, y - 0.31 * pitch, length, y + 0.31 * pitch))
    return g.extrude(contours, 0.0, thickness, round_m=min(0.0012, 0.25 * pitch))


_FORK = [(0.0, 0.28), (0.05, 0.32), (0.55, 0.20), (0.66, 0.11), (0.74, 0.42), (0.80, 0.5)]  # handle end -> tines


@register("fork", "length_m width_m thickness_m", "width_m*5 <= length_m", "thickness_m*5 <= width_m")
def build_fork(p: dict[str, float]) -> Built:
    """Table fork lying flat, length_m long along x with its four tines towards +x, head
    width_m wide, thickness_m thick. Two hulls: handle and head."""
    L, W = p["length_m"], p["width_m"]
    visual = _cutlery(_FORK, 4, L, W, p["thickness_m"])
    return g.finish(visual, g.piece_hulls(visual, 0, [0.70 * L]))


@register(
    "spoon",
    "length_m bowl_length_m bowl_width_m",
    "bowl_length_m*2.5 <= length_m",
    "bowl_width_m*1 <= bowl_length_m",
)
def build_spoon(p: dict[str, float]) -> Built:
    """Spoon resting on its bowl and handle end: an oval bowl bowl_length_m by bowl_width_m at
    +x, hollow and flat-bottomed, and a flat handle sloping down to the table; length_m overall.
    Two hulls: bowl and handle."""
    L, a, b = p["length_m"], p["bowl_length_m"] / 2, p["bowl_width_m"] / 2
    c, w, t = 0.28 * b, 0.0012, 0.0025  # bowl depth, shell and handle thickness
    centre = (L - a, 0.0, c)
    shell = g.difference(
        g.ellipsoid(centre, (a, b, c), 3),
        g.box((L - 3 * a, -b, c), (L + a, b, 3 * c)),
        g.ellipsoid((L - a, 0, c + 0.5 * w), (a - w, b - w, c - w), 3),
        g.box((L - 3 * a, -b, -c), (L + a, b, 0.1 * c)),
    )
    n = L - 2 * a + 0.3 * a  # handle length, overlapping the back of the bowl
    handle = g.extrude(
        [np.array([(0, -0.17 * b * 2), (n, -0.07 * b * 2), (n, 0.07 * b * 2), (0, 0.17 * b * 2)])], 0, t, 0.002
    )
    handle = g.rotated(handle, -math.atan2(0.75 * c, n), (0, 1, 0), (0, 0, 0))
    return g.finish(g.union([shell, handle]), [g.hull(shell.vertices), g.hull(handle.vertices)])


@register("knife", "length_m blade_width_m handle_thickness_m", "blade_width_m*6 <= length_m")
def build_knife(p: dict[str, float]) -> Built:
    """Table knife lying flat, length_m long: a rounded handle handle_thickness_m thick on -x
    and a thin blade blade_width_m wide with a rounded tip towards +x. Two hulls."""
    L, bw, ht = p["length_m"], p["blade_width_m"], p["handle_thickness_m"]
    handle = g.rounded_block((0, -0.45 * bw, 0), (0.42 * L, 0.45 * bw, ht), 0.45 * ht)
    rt = 0.25 * bw  # radius of the rounded tip, which ends exactly at x = length_m
    tip = [(L - rt + rt * math.cos(a), 0.05 * bw + rt * math.sin(a)) for a in np.linspace(-1.2, 1.4, 7)]
    edge = [(0.38 * L, -0.5 * bw), (0.80 * L, -0.5 * bw), (0.93 * L, -0.36 * bw)]
    spine = [(0.88 * L, 0.45 * bw), (0.38 * L, 0.45 * bw)]
    blade = g.extrude([np.array(edge + tip + spine)], 0, 0.002)
    return g.finish(g.union([handle, blade]), [g.hull(handle.vertices), g.hull(blade.vertices)])
