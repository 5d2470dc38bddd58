"""Office and desk things: book, stapler, pencil, glasses case, clock, candle, lamp."""

from __future__ import annotations

import math

import numpy as np
import trimesh

from . import geometry as g
from .registry import Built, register


@register("book", "cover_length_m cover_width_m thickness_m", "thickness_m*2 <= cover_width_m")
def build_book(p: dict[str, float]) -> Built:
    """Closed book lying flat: two covers, a page block inset on three sides and a rounded spine
    on +x; cover_width_m along x, cover_length_m along y, thickness_m tall."""
    L, W, t = p["cover_length_m"], p["cover_width_m"], p["thickness_m"]
    c, inset, xs = min(max(0.1 * t, 0.0015), 0.003), 0.015 * W, W / 2 - t / 4  # cover, page inset, spine axis
    slabs = [(-W / 2, L / 2, 0, c), (-W / 2, L / 2, t - c, t), (inset - W / 2, L / 2 - inset, c / 2, t - c / 2)]
    boxes = [g.box((x0, -y, z0), (xs, y, z1)) for x0, y, z0, z1 in slabs]
    spine = trimesh.creation.cylinder(radius=t / 2, height=L, sections=16)
    spine.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, (1, 0, 0)))
    spine.apply_scale((0.5, 1.0, 1.0))
    spine.apply_translation((xs, 0, t / 2))
    visual = g.union([*boxes, spine])
    return g.finish(visual, [g.hull(visual.vertices)])


@register("stapler", "length_m width_m height_m", "width_m*2.8 <= length_m", "height_m*0.55 <= width_m")
def build_stapler(p: dict[str, float]) -> Built:
    """Desk stapler length_m long with its head on +x, width_m wide, height_m tall: a flat base
    plate, a thick top arm rounded at the front and a hinge block at the back, with a small
    gap between arm and base at the front. Three hulls: base, arm, hinge."""
    L, W, H = p["length_m"], p["width_m"], p["height_m"]
    base = g.rounded_block((-L / 2, -0.5 * W, 0), (L / 2, 0.5 * W, 0.2 * H), 0.08 * H)
    hinge = g.rounded_block((-L / 2, -0.42 * W, 0.15 * H), (-0.28 * L, 0.42 * W, 0.75 * H), 0.12 * H)
    arm = g.hull(
        np.vstack(
            [
                g.rounded_block((-L / 2 + 0.003, -0.4 * W, 0.45 * H), (-0.1 * L, 0.4 * W, H), 0.3 * H).vertices,
                g.rounded_block((0.3 * L, -0.4 * W, 0.3 * H), (L / 2 - 0.002, 0.4 * W, 0.85 * H), 0.25 * H).vertices,
            ]
        )
    )
    anvil = g.box((0.3 * L, -0.15 * W, 0.19 * H), (0.45 * L, 0.15 * W, 0.23 * H))
    visual = g.union([base, hinge, arm, anvil])
    return g.finish(visual, [g.hull(base.vertices), g.hull(arm.vertices), g.hull(hinge.vertices)])


@register("pencil", "length_m radius_m", "radius_m*25 <= length_m")
def build_pencil(p: dict[str, float]) -> Built:
    """Hexagonal pencil length_m long lying on a flat face, radius_m across the corners: a
    sharpened cone with a lead tip on +x, a metal ferrule and an eraser on -x. One hull."""
    L, r = p["length_m"], p["radius_m"]
    cone, band = 0.12 * L, 0.06 * L

    def hexagon(x0: float, x1: float, rad: float) -> trimesh.Trimesh:
        a = np.linspace(0, 2 * math.pi, 6, endpoint=False)  # corners at 240 and 300 deg: a face underneath
        ring = np.column_stack([rad * np.cos(a), rad * np.sin(a)])
        return g.hull(np.vstack([np.column_stack([np.full(6, x), ring]) for x in (x0, x1)]))

    shaft = hexagon(-L / 2 + 2 * band, L / 2 - cone, r)
    wood = g.hull(np.vstack([shaft.vertices[shaft.vertices[:, 0] > 0], [(L / 2 - 0.15 * cone, 0, 0)]]))
    ferrule = g.rotated(g.cylinder(0.95 * r, (0, 0, 0), (0, 0, band), 12), math.pi / 2, g.Y)
    ferrule = g.moved(ferrule, (-L / 2 + band, 0, 0))
    rubber = g.moved(
        g.rotated(g.cylinder(0.88 * r, (0, 0, 0), (0, 0, band + 0.001), 12), math.pi / 2, g.Y), (-L / 2, 0, 0)
    )
    lead = g.hull(
        [(L / 2 - 0.2 * cone, dy, dz) for dy, dz in ((0.3 * r, 0), (-0.3 * r, 0), (0, 0.3 * r), (0, -0.3 * r))]
        + [(L / 2, 0, 0)]
    )
    visual = g.union([shaft, wood, ferrule, rubber, lead])
    visual.apply_translation((0, 0, r * math.cos(math.pi / 6)))  # rest on a flat face
    return g.finish(visual, [g.hull(visual.vertices)])


@register("glasses_case", "length_m width_m height_m", "width_m*1.5 <= length_m", "height_m*1 <= width_m")
def build_glasses_case(p: dict[str, float]) -> Built:
    """Hard glasses case lying flat, length_m along y, width_m deep, height_m tall: a rounded
    pill-shaped shell with the seam between lid and base running round it, and the hinge at
    the back (-x). One hull."""
    L, W, H = p["length_m"], p["width_m"], p["height_m"]
    shell = g.difference(
        g.ellipsoid((0, 0, H / 2), (W / 2, L / 2, H / 2 * 1.35), 3),
        g.box((-W, -L, -H), (W, L, 0)),
        g.box((-W, -L, H), (W, L, 2 * H)),
    )
    shell = g.union([shell, g.rounded_slab(W / 2 * 0.96, L / 2 * 0.96, 0, 0.5 * H, 0.45 * W, 10)])
    seam = g.difference(
        g.box((-W, -L, 0.52 * H), (W, L, 0.56 * H)),
        g.rounded_slab(W / 2 * 0.97 - 0.0015, L / 2 * 0.97 - 0.0015, 0, H, 0.45 * W - 0.0015, 10),
    )
    hinge = g.moved(
        g.rotated(g.cylinder(0.08 * H, (0, 0, 0), (0, 0, 0.3 * L), 10), math.pi / 2, g.X),
        (-W / 2 * 0.93, 0.15 * L, 0.54 * H),
    )
    visual = g.union([g.difference(shell, seam), hinge])
    return g.finish(visual, [g.hull(visual.vertices)])


@register("clock", "radius_m depth_m", "depth_m*1.1 <= radius_m")
def build_clock(p: dict[str, float]) -> Built:
    """Twin-bell alarm clock facing +x: a round case of radius_m and depth_m standing on two
    flat-soled feet wider than the case is deep (so it does not tip), a face with a raised
    bezel, hour marks and two hands, two bells and a hammer on top.
    Hulls: case with feet, and each bell."""
    R, D = p["radius_m"], p["depth_m"]
    zc = R + 0.18 * R  # the feet lift the case
    case = g.rotated(g.cylinder(R, (0, 0, -D / 2), (0, 0, D / 2), 32), math.pi / 2, g.Y)
    bezel = g.rotated(
        trimesh.creation.torus(major_radius=0.92 * R, minor_radius=0.07 * R, major_sections=32, minor_sections=6),
        math.pi / 2,
        g.Y,
    )
    bezel.apply_translation((D / 2, 0, 0))
    marks = [g.box((D / 2, -0.03 * R, 0.62 * R), (D / 2 + 0.05 * R, 0.03 * R, 0.76 * R)) for _ in range(12)]
    marks = [g.rotated(m, k * math.pi / 6, g.X) for k, m in enumerate(marks)]
    hands = [
        g.rotated(g.box((D / 2, -0.035 * R, 0), (D / 2 + 0.06 * R, 0.035 * R, length * R)), angle, g.X)
        for length, angle in ((0.45, 1.0), (0.65, -2.2))
    ]
    pin = g.rotated(g.cylinder(0.08 * R, (0, 0, D / 2), (0, 0, D / 2 + 0.09 * R), 10), math.pi / 2, g.Y)
    face = g.moved(g.union([case, bezel, *marks, *hands]), (0, 0, zc))
    bells = [
        g.moved(
            g.rotated(
                g.difference(g.ellipsoid((0, 0, 0), (0.38 * R,) * 3, 2), g.box((-R, -R, -R), (R, R, 0))),
                s * math.radians(35),
                g.X,
            ),
            (0, s * 0.55 * R, zc + 0.85 * R),
        )
        for s in (1, -1)
    ]
    hammer = g.cylinder(0.05 * R, (0, 0, zc + 0.95 * R), (0, 0, zc + 1.25 * R), 8)
    feet = [
        g.difference(
            g.ellipsoid((0, s * 0.6 * R, 0.11 * R), (0.4 * R, 0.14 * R, 0.11 * R), 2),
            g.box((-R, -R, -R), (R, R, 0.03 * R)),
        )
        for s in (1, -1)
    ]
    feet = [
        g.union([f, g.cylinder(0.06 * R, (0, s * 0.6 * R, 0.09 * R), (0, s * 0.55 * R, zc), 8)])
        for f, s in zip(feet, (1, -1))
    ]
    visual = g.union([face, g.moved(pin, (0, 0, zc)), *bells, hammer, *feet])
    body_parts = [g.hull(np.vstack([face.vertices, *[f.vertices for f in feet]])), *[g.hull(b.vertices) for b in bells]]
    return g.finish(visual, body_parts)


@register("candle", "radius_m height_m", "radius_m*1 <= height_m")
def build_candle(p: dict[str, float]) -> Built:
    """Pillar candle of radius_m and height_m whose top has melted into a shallow dip, with a
    slightly bent wick standing in the middle. Two hulls: wax and wick."""
    R, H = p["radius_m"], p["height_m"]
    dip = 0.12 * R
    wax = g.revolve(
        [
            (0, 0),
            (R, 0),
            (R, H - 0.02 * R),
            *g.arc(R - 0.06 * R, H - 0.02 * R, 0.06 * R, 0, math.pi / 2, 4)[1:],
            (0.75 * R, H - 0.25 * dip),
            (0.4 * R, H - 0.9 * dip),
            (0, H - dip),
        ],
        40,
    )
    path = np.array(
        [(0, 0, H - dip - 0.002), (0, 0, H - dip + 0.008), (0.002, 0, H - dip + 0.014), (0.0045, 0, H - dip + 0.017)]
    )
    wick = g.rod(path, 0.0011, g.Y, 6)
    visual = g.union([wax, wick])
    return g.finish(visual, [g.hull(wax.vertices), g.hull(wick.vertices)])


@register(
    "lamp", "height_m base_radius_m shade_radius_m", "shade_radius_m*1 <= base_radius_m", "base_radius_m*2 <= height_m"
)
def build_lamp(p: dict[str, float]) -> Built:
    """Desk lamp height_m tall: a heavy round base of base_radius_m, an upright post, an arm
    reaching forward (+x) and a conical shade of shade_radius_m pointing down at the desk in
    front. Hulls: base, post, arm and shade."""
    H, rb, rs = p["height_m"], p["base_radius_m"], p["shade_radius_m"]
    tb = 0.09 * H  # base thickness
    base = g.revolve(
        [
            (0, 0),
            (rb, 0),
            *g.arc(rb - 0.3 * tb, 0.7 * tb, 0.3 * tb, 0, math.pi / 2, 4),
            (0.35 * rb, tb),
            (0.3 * rb, 1.3 * tb),
            (0, 1.3 * tb),
        ],
        40,
    )
    x0 = -0.45 * rb  # the post stands at the back of the base
    joint = np.array([x0, 0, H - 0.016])  # the knuckle's top is the lamp's top
    tip = np.array([x0 + 0.9 * rb + 0.4 * rs, 0, H - 0.045])
    post = g.cylinder(0.012, (x0, 0, tb), joint, 12)
    arm = g.cylinder(0.009, joint, tip, 12)
    knuckle = g.ellipsoid(joint, (0.016,) * 3, 1)
    hs = 0.75 * rs * 1.3  # shade height
    shade = g.revolve([(0, 0), (rs, 0), (rs * 0.98, 0.06 * hs), (0.35 * rs, hs), (0, hs)], 32)
    shade = g.moved(g.rotated(shade, math.radians(25), g.Y), tip - (0, 0, hs * 0.85))
    visual = g.union([base, post, arm, knuckle, shade])
    parts = [g.hull(base.vertices), g.hull(post.vertices), g.hull_of(arm, knuckle), g.hull(shade.vertices)]
    return g.finish(visual, parts, centre=False)
