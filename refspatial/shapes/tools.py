"""Hand tools: scissors, hammer, screwdriver."""

from __future__ import annotations

import math

import numpy as np

from . import geometry as g
from .registry import Built, register


def _ring(cx: float, cy: float, rx: float, ry: float, band: float, n: int = 20) -> list[np.ndarray]:
    """An oval finger loop as (outer counter-clockwise, inner clockwise) outlines."""
    a = np.linspace(0, 2 * math.pi, n, endpoint=False)
    outer = np.column_stack([cx + rx * np.cos(a), cy + ry * np.sin(a)])
    inner = np.column_stack([cx + (rx - band) * np.cos(a), cy + (ry - band) * np.sin(a)])[::-1]
    return [outer, inner]


@register("scissors", "length_m blade_ratio", "blade_ratio*1 <= 0.65")
def build_scissors(p: dict[str, float]) -> Built:
    """Scissors lying flat and closed to a narrow V, length_m from the finger loops to the tips
    (+x); blade_ratio of the length is blade. Two pointed blades cross at a pivot screw; the
    two finger loops (one bigger) sit at -x, one layer above the other. Hulls: each blade with
    its shank, each loop, the pivot."""
    L, k = p["length_m"], p["blade_ratio"]
    lb, t = k * L, 0.0022  # blade length, blade thickness
    pivot = np.array([L / 2 - lb, 0.0])
    parts, pieces = [], []
    for side, z0 in ((1, 0.0), (-1, t)):
        spread = math.radians(2.5) * side
        tip = pivot + lb * np.array([math.cos(spread), math.sin(spread)])
        normal = np.array([-math.sin(spread), math.cos(spread)])
        blade = [
            pivot - 0.006 * normal * side,
            tip - 0.0015 * normal * side,
            tip + 0.001 * normal * side,
            pivot + 0.011 * normal * side,
        ]
        loop_c = np.array([-L / 2 + 0.026, side * 0.02])
        shank = [
            pivot + 0.005 * normal,
            loop_c + (0.018, -0.007 * side),
            loop_c + (0.02, 0.008 * side),
            pivot - 0.005 * normal,
        ]
        rx, ry = (0.026, 0.017) if side > 0 else (0.021, 0.015)
        outlines = [np.array(blade if side < 0 else blade[::-1]), np.array(shank if side > 0 else shank[::-1])]
        loop = g.extrude(_ring(float(loop_c[0]), float(loop_c[1]), rx, ry, 0.006), 0.0, 2.5 * t)
        flat = g.extrude([o if _ccw(o) else o[::-1] for o in outlines], z0, z0 + t, 0.0004)
        pieces += [flat, loop]
        parts += [g.hull(flat.vertices), g.hull(loop.vertices)]
    screw = g.cylinder(0.004, (*pivot, 0), (*pivot, 2.6 * t), 12)
    return g.finish(g.union([*pieces, screw]), parts + [g.hull(screw.vertices)])


def _ccw(points: np.ndarray) -> bool:
    x, y = np.asarray(points).T
    return float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) > 0


@register("hammer", "length_m head_m", "head_m*2 <= length_m")
def build_hammer(p: dict[str, float]) -> Built:
    """Claw hammer lying on its side, length_m from handle end to head (+x) and head_m across
    the head (along y): a rounded handle, a square head with a round striking face on +y and
    a curved, split claw on -y. Two hulls: handle and head."""
    L, hl = p["length_m"], p["head_m"]
    s = 0.24 * hl  # side of the head's square section
    handle = g.rounded_block((-L / 2, -0.012, 0.003), (L / 2 - 0.6 * s, 0.012, s - 0.003), 0.008)
    hx = L / 2 - s / 2
    block = g.rounded_block((hx - s / 2, -0.1 * hl, 0), (hx + s / 2, 0.28 * hl, s), 0.1 * s)
    face = g.rotated(g.cylinder(0.42 * s, (0, 0, 0), (0, 0, 0.2 * hl), 16), -math.pi / 2, g.X)
    face = g.moved(face, (hx, 0.28 * hl, s / 2))
    a = np.linspace(0, 0.9, 7)
    path = np.column_stack(
        [hx - 0.35 * hl * (1 - np.cos(a)) * 0.5, -0.1 * hl - 0.38 * hl * np.sin(a), np.full_like(a, s / 2)]
    )
    claw = g.tube(g.tube_rings(path, 0.45 * s * (1 - 0.55 * a / 0.9), g.Z, 8), path)
    claw = g.difference(claw, g.box((hx - hl, -hl, s / 2 - 0.06 * s), (hx + hl, -0.25 * hl, s / 2 + 0.06 * s)))
    head = g.union([block, face, claw])
    return g.finish(g.union([handle, head]), [g.hull(handle.vertices), g.hull(head.vertices)])


@register("screwdriver", "length_m handle_radius_m", "handle_radius_m*11 <= length_m")
def build_screwdriver(p: dict[str, float]) -> Built:
    """Screwdriver lying on its side, length_m from the handle end to the flat tip (+x): a
    fluted octagonal handle of handle_radius_m (so it lies on a facet and does not roll),
    a steel shaft and a flattened blade tip. Two hulls: handle, shaft."""
    L, R = p["length_m"], p["handle_radius_m"]
    lh = 0.42 * L
    a = np.linspace(0, 2 * math.pi, 8, endpoint=False) + math.pi / 8
    octagon = np.column_stack([R * np.cos(a), R * np.sin(a)])
    rings = [
        np.column_stack([np.full(8, x), octagon * k])
        for x, k in ((-L / 2, 0.82), (-L / 2 + 0.02 * L, 1.0), (-L / 2 + 0.8 * lh, 1.0), (-L / 2 + lh, 0.7))
    ]
    handle = g.hull(np.vstack(rings))
    flutes = [
        g.cylinder(
            0.22 * R,
            (-L / 2 + 0.1 * lh, 1.05 * R * math.cos(b), 1.05 * R * math.sin(b)),
            (-L / 2 + 0.75 * lh, 1.05 * R * math.cos(b), 1.05 * R * math.sin(b)),
            8,
        )
        for b in a + math.pi / 8
    ]
    rs = 0.22 * R
    shaft = g.rotated(g.cylinder(rs, (0, 0, 0), (0, 0, L - lh - 0.06 * L + 0.01), 12), math.pi / 2, g.Y)
    shaft = g.moved(shaft, (-L / 2 + lh - 0.01, 0, 0))
    tip = g.hull(
        [(L / 2 - 0.065 * L, dy, dz) for dy in (-rs, rs) for dz in (-rs, rs)]
        + [(L / 2, dy, dz) for dy in (-1.3 * rs, 1.3 * rs) for dz in (-0.25 * rs, 0.25 * rs)]
    )
    visual = g.union([g.difference(handle, *flutes), shaft, tip])
    return g.finish(visual, [g.hull(handle.vertices), g.hull_of(shaft, tip)])  # it rests on the facet at -z
