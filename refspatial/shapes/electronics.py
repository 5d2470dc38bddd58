"""Electronics: laptop, keyboard, phone, remote control, computer mouse."""

from __future__ import annotations

import math

import numpy as np
import trimesh

from . import geometry as g
from .registry import Built, register


def _keys(x0: float, x1: float, y0: float, y1: float, rows: int, cols: int, gap: float) -> list[np.ndarray]:
    """Outlines of a grid of key caps over the rectangle, rows along x and columns along y; the
    row nearest +x (the typist) has a wide space bar in the middle."""
    pitch_x, pitch_y = (x1 - x0) / rows, (y1 - y0) / cols
    caps = []
    for i in range(rows):
        xa, xb = x0 + i * pitch_x + gap / 2, x0 + (i + 1) * pitch_x - gap / 2
        spans = [(j, j + 1) for j in range(cols)]
        if i == rows - 1:  # space bar row
            j0, j1 = cols // 2 - 3, cols // 2 + 3
            spans = [(j, j + 1) for j in range(j0)] + [(j0, j1)] + [(j, j + 1) for j in range(j1, cols)]
        caps += [g.rect(xa, y0 + ja * pitch_y + gap / 2, xb, y0 + jb * pitch_y - gap / 2) for ja, jb in spans]
    return caps


@register(
    "laptop",
    "width_m depth_m thickness_m screen_angle_deg",
    "depth_m*1.1 <= width_m",
    "thickness_m*8 <= depth_m",
    "screen_angle_deg*1 <= 130",
)
def build_laptop(p: dict[str, float]) -> Built:
    """Open laptop facing +x: a base width_m across (y) and depth_m deep (x), thickness_m thick,
    with a key grid and a touchpad, and a thin screen hinged on the back edge, opened
    screen_angle_deg from the base, its inset display facing +x. Two hulls: base and screen."""
    W, D, t, angle = p["width_m"], p["depth_m"], p["thickness_m"], math.radians(p["screen_angle_deg"])
    base = g.rounded_block((-D / 2, -W / 2, 0), (D / 2, W / 2, t), 0.35 * t)
    well = g.box((-0.42 * D, -0.44 * W, t - 0.0012), (0.06 * D, 0.44 * W, 2 * t))
    pad = g.box((0.16 * D, -0.14 * W, t - 0.0008), (0.43 * D, 0.14 * W, 2 * t))
    keys = g.extrude(_keys(-0.41 * D, 0.05 * D, -0.43 * W, 0.43 * W, 5, 14, 0.0025), t - 0.0012, t + 0.0002)
    st = 0.6 * t  # screen thickness
    sh = 0.92 * D  # screen height
    screen = g.rounded_block((0, -W / 2, 0), (st, W / 2, sh), 0.3 * st)
    display = g.box((st - 0.0008, -0.46 * W, 0.07 * sh), (2 * st, 0.46 * W, 0.95 * sh))
    screen = g.difference(screen, display)
    # open the lid: lean it back from vertical by (angle - 90 deg) about the hinge line
    screen = g.rotated(screen, -(angle - math.pi / 2), g.Y)
    screen.apply_translation((-D / 2 - 0.2 * st, 0, 0.8 * t))
    visual = g.union([g.difference(base, well, pad), keys, screen])
    return g.finish(visual, [g.hull(base.vertices), g.hull(screen.vertices)])


@register("keyboard", "width_m depth_m height_m", "depth_m*2.5 <= width_m", "height_m*4 <= depth_m")
def build_keyboard(p: dict[str, float]) -> Built:
    """Computer keyboard width_m across (y), depth_m deep (x), height_m tall at the back: a
    wedge-shaped case rising away from the typist (+x) with six rows of key caps, a space bar
    in the front row and a number block on the right. One hull."""
    W, D, H = p["width_m"], p["depth_m"], p["height_m"]
    front_h = 0.55 * H
    outline = g.rounded_slab(D / 2, W / 2, 0, 0, 0.01, 4).vertices
    top = outline.copy()
    top[:, 2] = H + (front_h - H) * (top[:, 0] + D / 2) / D  # rising away from the typist
    case = g.hull(np.vstack([outline, top]))
    outlines = _keys(-0.44 * D, 0.42 * D, -0.47 * W, 0.22 * W, 6, 15, 0.0022)
    outlines += _keys(-0.44 * D, 0.42 * D, 0.26 * W, 0.47 * W, 6, 4, 0.0022)[:-4]  # number block
    keys = g.extrude(outlines, -0.002, 0.004)
    keys.vertices[:, 2] += H + (front_h - H) * (keys.vertices[:, 0] + D / 2) / D  # follow the sloping top
    visual = g.union([case, keys])
    return g.finish(visual, [g.hull(visual.vertices)])


@register("phone", "length_m width_m thickness_m", "width_m*1.6 <= length_m", "thickness_m*6 <= width_m")
def build_phone(p: dict[str, float]) -> Built:
    """Smartphone lying screen up, length_m along x with its earpiece end on +x, width_m wide
    and thickness_m thick: a rounded slab with an inset screen, an earpiece slot and a front
    camera dot. One hull."""
    L, W, t = p["length_m"], p["width_m"], p["thickness_m"]
    body = g.rounded_block((-L / 2, -W / 2, 0), (L / 2, W / 2, t), 0.3 * t)
    body = g.union([body, g.rounded_slab(L / 2, W / 2, 0.25 * t, 0.75 * t, 0.12 * W, 6)])
    screen = g.rounded_slab(L / 2 - 0.05 * L, W / 2 - 0.05 * W, t - 0.0006, 2 * t, 0.09 * W, 6)
    slot = g.extrude([g.rect(L / 2 - 0.035 * L, -0.1 * W, L / 2 - 0.028 * L, 0.1 * W)], t - 0.0006, 2 * t, 0.0003)
    camera = g.cylinder(0.025 * W, (L / 2 - 0.032 * L, 0.2 * W, t - 0.0006), (L / 2 - 0.032 * L, 0.2 * W, 2 * t), 10)
    visual = g.difference(body, screen, slot, camera)
    return g.finish(visual, [g.hull(visual.vertices)])


@register("remote", "length_m width_m thickness_m", "width_m*2.9 <= length_m", "thickness_m*1.5 <= width_m")
def build_remote(p: dict[str, float]) -> Built:
    """TV remote control length_m along x with its power button on +x, width_m wide and
    thickness_m thick: a rounded bar with a round power button, a cross-shaped pad and a grid
    of small round buttons. One hull."""
    L, W, t = p["length_m"], p["width_m"], p["thickness_m"]
    body = g.rounded_block((-L / 2, -W / 2, 0), (L / 2, W / 2, t), 0.35 * t)
    r = 0.09 * W
    buttons = [g.cylinder(1.3 * r, (0.40 * L, 0.22 * W, t - 0.001), (0.40 * L, 0.22 * W, t + 0.0015), 14)]
    for dx, dy in ((0, 0), (0.045 * L, 0), (-0.045 * L, 0), (0, 0.2 * W), (0, -0.2 * W)):  # navigation pad
        buttons.append(g.cylinder(r, (0.18 * L + dx, dy, t - 0.001), (0.18 * L + dx, dy, t + 0.0012), 10))
    for i in range(5):
        for j in (-1, 0, 1):
            x, y = -0.05 * L - i * 0.075 * L, j * 0.27 * W
            buttons.append(g.cylinder(r, (x, y, t - 0.001), (x, y, t + 0.001), 10))
    visual = g.union([body, *buttons])
    return g.finish(visual, [g.hull(visual.vertices)])


@register("mouse", "length_m width_m height_m", "width_m*1.2 <= length_m", "height_m*1 <= width_m")
def build_mouse(p: dict[str, float]) -> Built:
    """Computer mouse length_m long with its buttons on +x, width_m wide and height_m tall: a
    dome highest behind the middle (under the palm), flat underneath, with a groove between
    the two buttons and a scroll wheel in it. One hull."""
    L, W, H = p["length_m"], p["width_m"], p["height_m"]
    dome = g.ellipsoid((0, 0, 0), (L / 2, W / 2, H), 3)
    v = dome.vertices.copy()
    v[:, 2] = np.sign(v[:, 2]) * H * (np.abs(v[:, 2]) / H) ** 0.6  # steep sides, a flatter top
    v[:, 2] *= 1 - 0.25 * (v[:, 0] / (L / 2))  # the front (+x) slopes lower than the back
    v[:, 1] *= 1 - 0.12 * np.clip(v[:, 0] / (L / 2), 0, 1)  # and narrows a little
    dome = g.difference(trimesh.Trimesh(v, dome.faces), g.box((-L, -W, -2 * H), (L, W, 0)))
    lowered = g.moved(dome, (0, 0, -0.0025))
    split = g.difference(g.box((0.05 * L, -0.0007, 0), (L, 0.0007, 2 * H)), lowered)  # between the buttons
    wheel_x = 0.27 * L
    well = g.difference(g.box((wheel_x - 0.11 * L, -0.0045, 0), (wheel_x + 0.11 * L, 0.0045, 2 * H)), lowered)
    wheel_z = H * (1 - (wheel_x / (L / 2)) ** 2) ** 0.3 * (1 - 0.25 * wheel_x / (L / 2)) - 0.07 * L
    wheel = g.cylinder(0.09 * L, (wheel_x, -0.003, wheel_z), (wheel_x, 0.003, wheel_z), 16)
    visual = g.union([g.difference(dome, split, well), wheel])
    return g.finish(visual, [g.hull(visual.vertices)])
