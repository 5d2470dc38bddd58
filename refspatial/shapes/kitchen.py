"""Kitchen things: bottle, can, jar, teapot, pan, pot, cutting board, sponge."""

from __future__ import annotations

import math

import numpy as np

from . import geometry as g
from .registry import Built, register


@register(
    "bottle",
    "radius_m height_m neck_radius_m neck_m shoulder_m",
    "neck_radius_m*1.3 <= radius_m",
    "neck_m*3 <= height_m",
    "shoulder_m*3 <= height_m",
)
def build_bottle(p: dict[str, float]) -> Built:
    """Solid revolved bottle: a cylinder of radius_m, a shoulder_m tall curve in to a neck of
    neck_radius_m and neck_m length topped by a slightly wider cap; height_m overall."""
    R, h, rn, neck, sh = p["radius_m"], p["height_m"], p["neck_radius_m"], p["neck_m"], p["shoulder_m"]
    body, e, rc, cap = h - neck - sh, 0.1 * R, 1.12 * rn, 0.35 * neck
    u = np.linspace(0, 1, 9)
    shoulder = np.column_stack([rn + (R - rn) * (1 + np.cos(math.pi * u)) / 2, body + sh * u])
    visual = g.revolve([(0, 0), (R - e, 0), (R, e), *shoulder, (rn, h - cap), (rc, h - cap), (rc, h), (0, h)])
    return g.finish(visual, [g.hull(visual.vertices)])


@register("can", "radius_m height_m")
def build_can(p: dict[str, float]) -> Built:
    """Drink can of radius_m and height_m: domed bottom, necked top, raised rim (scaled by the radius)."""
    R, h = p["radius_m"], p["height_m"]
    e = 0.12 * R
    bottom = [(0, 0.6 * e), (R - e, 0), (R - 0.4 * e, 0), (R, 0.6 * e)]
    top = [(R, h - 1.5 * e), (R - 0.5 * e, h - 0.3 * e), (R - 0.5 * e, h), (R - 0.9 * e, h), (R - 0.9 * e, h - 0.5 * e)]
    visual = g.revolve([*bottom, *top, (0, h - 0.5 * e)])
    return g.finish(visual, [g.hull(visual.vertices)])


@register(
    "jar",
    "radius_m height_m mouth_radius_m wall_m base_m",
    "mouth_radius_m*1.05 <= radius_m",
    "wall_m*5 <= mouth_radius_m",
    "base_m*6 <= height_m",
)
def build_jar(p: dict[str, float]) -> Built:
    """Open storage jar: a straight body of radius_m, a rounded shoulder into a threaded neck
    of mouth_radius_m, height_m tall, wall_m thick walls and base_m thick bottom. Hollow in
    physics too (a floor and wall wedges in bands), so things fit through the mouth."""
    R, h, rm, w, b = p["radius_m"], p["height_m"], p["mouth_radius_m"], p["wall_m"], p["base_m"]
    z = np.concatenate(
        [
            [0.0, 0.01 * h],
            np.linspace(0.03 * h, 0.70 * h, 4),
            np.linspace(0.74 * h, 0.84 * h, 5),
            np.linspace(0.87 * h, h, 7),
        ]
    )
    smooth = g.blend(z, [0.0, 0.03 * h, 0.70 * h, 0.84 * h, h], [R - 0.006, R, R, rm, rm])
    on_neck = (z > 0.87 * h) & (z < 0.97 * h)
    thread = 0.0015 * on_neck * (np.abs(np.sin((z - 0.86 * h) / (0.14 * h) * 2 * math.pi)) > 0.5)  # two ridges
    visual, parts = g.vessel(z, smooth + thread, smooth - w, b, bands=3)
    return g.finish(visual, parts)


def _teapot_body(R: float, hb: float, top: float) -> list:
    """(r, z) profile of a closed teapot: foot, belly, shoulder, lid and knob, up to `top`."""
    z = np.linspace(0, hb, 14)
    r = g.blend(z, [0, 0.12 * hb, 0.45 * hb, hb], [0.62 * R, 0.82 * R, R, 0.56 * R])
    lid_top, k = hb + 0.55 * (top - hb), 0.12 * R
    dome = g.arc(0, hb, 0.52 * R, 0.0, math.pi / 2, 8)
    dome = [(x, hb + 0.012 + (y - hb) * (lid_top - hb - 0.012) / (0.52 * R)) for x, y in dome if x > 0.9 * k]
    knob = [
        (k, lid_top),
        (1.3 * k, lid_top + 0.35 * (top - lid_top)),
        (1.1 * k, top - 0.2 * (top - lid_top)),
        (0.5 * k, top),
        (0, top),
    ]
    return [(0, 0), *zip(r, z), (0.6 * R, hb + 0.012), *dome, *knob]


@register("teapot", "radius_m height_m spout_m", "spout_m*0.7 <= radius_m", "radius_m*1 <= height_m")
def build_teapot(p: dict[str, float]) -> Built:
    """Lidded teapot height_m tall with a belly of radius_m, a spout reaching spout_m beyond the
    belly on +x and a D-shaped handle on -x. Three hulls (body, spout, handle); the lid makes it
    closed, so it has no cavity. The body, not the footprint, is centred on the origin."""
    R, h, s = p["radius_m"], p["height_m"], p["spout_m"]
    hb = 0.68 * h
    body = g.revolve(_teapot_body(R, hb, h))
    t = np.linspace(0, 1, 12)[:, None]
    p0, p1, p2 = (
        np.array([0.7 * R, 0, 0.3 * hb]),
        np.array([R + 0.45 * s, 0, 0.3 * hb]),
        np.array([R + s, 0, 1.05 * hb]),
    )
    path = (1 - t) ** 2 * p0 + 2 * (1 - t) * t * p1 + t**2 * p2
    spout = g.tube(g.tube_rings(path, R * (0.2 - 0.1 * t[:, 0]), g.Y, 14), path)
    a = np.linspace(0, math.pi, 13)
    loop = np.column_stack([-(0.78 * R + 0.42 * R * np.sin(a)), 0 * a, hb * (0.52 + 0.34 * np.cos(a))])
    handle = g.rod(loop, 0.075 * R, g.Y, 10)
    visual = g.union([body, spout, handle])
    return g.finish(visual, [g.hull(body.vertices), g.hull(spout.vertices), g.hull(handle.vertices)], centre=False)


@register(
    "pan",
    "radius_m height_m handle_length_m wall_m",
    "wall_m*9 <= height_m",
    "height_m*1.8 <= radius_m",
    "handle_length_m*0.5 <= radius_m",
)
def build_pan(p: dict[str, float]) -> Built:
    """Frying pan: a shallow open pan whose flared wall reaches radius_m at a rim height_m high,
    wall_m thick, and a flat handle handle_length_m long rising gently on +x, with a hanging
    hole. Hollow in physics. The pan, not the footprint, is centred on the origin."""
    R, h, Lh, w = p["radius_m"], p["height_m"], p["handle_length_m"], p["wall_m"]
    rb = 0.78 * R
    z = np.linspace(0, h, 9)
    r_out = rb + (R - rb) * (z / h) ** 0.7
    visual, parts = g.vessel(z, r_out, r_out - w, 1.3 * w, bands=2)
    ht, hw = 0.010, 0.013  # handle section: thickness and half width
    handle = g.rounded_block((0, -hw, -ht / 2), (Lh, hw, ht / 2), 0.45 * ht)
    handle = g.difference(handle, g.cylinder(0.28 * hw, (Lh - 2 * hw, 0, -ht), (Lh - 2 * hw, 0, ht), 12))
    handle = g.moved(g.rotated(handle, -math.radians(12), g.Y), (R - 2 * w, 0, h - 0.6 * ht))
    return g.finish(g.union([visual, handle]), parts + [g.hull(handle.vertices)], centre=False)


@register("pot", "radius_m height_m wall_m", "wall_m*12 <= radius_m", "radius_m*0.8 <= height_m")
def build_pot(p: dict[str, float]) -> Built:
    """Cooking pot: an open straight-sided pot of radius_m and height_m with wall_m walls, a
    rolled rim and two loop handles sticking out sideways (+-y) below the rim. Hollow in physics."""
    R, h, w = p["radius_m"], p["height_m"], p["wall_m"]
    z = np.concatenate([[0.0], R * 0.06 * (1 - np.cos(np.linspace(0.3, math.pi / 2, 4))), np.linspace(0.1 * h, h, 6)])
    z = np.unique(np.clip(z, 0, h))
    r_out = R - 0.06 * R * np.clip(1 - z / (0.06 * R), 0, 1) ** 2
    visual, parts = g.vessel(z, r_out, r_out - w, 1.5 * w, bands=1)
    handles = []
    for side in (1, -1):
        a = np.linspace(-math.pi / 2, math.pi / 2, 9)
        loop = np.column_stack([0.32 * R * np.sin(a), side * (R - w + 0.035 * np.cos(a)), np.full_like(a, 0.86 * h)])
        handles.append(g.rod(loop, 0.0045, g.Z, 10))
    return g.finish(g.union([visual, *handles]), parts + [g.hull(hd.vertices) for hd in handles])


@register(
    "cutting_board",
    "length_m width_m thickness_m",
    "width_m*1 <= length_m",
    "thickness_m*8 <= width_m",
)
def build_cutting_board(p: dict[str, float]) -> Built:
    """Rounded-rectangle board length_m along x, width_m across, thickness_m thick, with a slot
    to hang it by near the +x end (its handle) and a juice groove round the top. One hull; a
    support for things put on it."""
    L, W, t = p["length_m"], p["width_m"], p["thickness_m"]
    corner = 0.1 * W
    board = g.rounded_slab(L / 2, W / 2, 0, t, corner, 8)
    slot = g.extrude([g.rect(L / 2 - 0.09 * L, -0.22 * W, L / 2 - 0.055 * L, 0.22 * W)], -t, 2 * t, round_m=0.0085 * L)
    inset, gw = 0.045 * W, 0.006
    ring = g.difference(
        g.rounded_slab(L / 2 - 0.13 * L, W / 2 - inset, t - 0.0025, 2 * t, corner, 8),
        g.rounded_slab(L / 2 - 0.13 * L - gw, W / 2 - inset - gw, t - 0.0030, 2.1 * t, corner, 8),
    )
    visual = g.difference(board, slot, g.moved(ring, (-0.045 * L, 0, 0)))
    return g.finish(visual, [g.hull(board.vertices)])


@register("sponge", "length_m width_m height_m", "height_m*1.5 <= width_m", "width_m*1 <= length_m")
def build_sponge(p: dict[str, float]) -> Built:
    """Kitchen sponge: a soft block length_m by width_m by height_m, pinched at the waist for
    the grip, with a groove where the scouring layer (the top third) meets the foam and pores
    in the foam's sides. One hull."""
    L, W, H = p["length_m"], p["width_m"], p["height_m"]
    x = np.linspace(-L / 2, L / 2, 9)
    half = W / 2 * (1 - 0.12 * np.cos(math.pi * x / L) ** 2)  # narrowest in the middle
    block = g.extrude(
        [np.vstack([np.column_stack([x, -half]), np.column_stack([x, half])[::-1]])], 0, H, round_m=0.12 * W
    )
    groove = g.difference(
        g.box((-L, -W, 0.64 * H), (L, W, 0.68 * H)),
        g.extrude(
            [np.vstack([np.column_stack([x, -half + 0.002]), np.column_stack([x, half - 0.002])[::-1]])],
            0,
            H,
            round_m=0.12 * W,
        ),
    )
    pores = [
        g.ellipsoid((fx * L, sy * float(np.interp(fx * L, x, half)), (0.18 + 0.14 * (k % 3)) * H), (0.0045,) * 3, 1)
        for k, (fx, sy) in enumerate(
            [(-0.36, 1), (-0.12, 1), (0.1, 1), (0.33, 1), (-0.3, -1), (-0.05, -1), (0.2, -1), (0.38, -1)]
        )
    ]
    visual = g.difference(block, groove, *pores)
    return g.finish(visual, [g.hull(block.vertices)])
