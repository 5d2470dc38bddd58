"""Fruit and food: apple, banana, orange, lemon, bread, cake, donut."""

from __future__ import annotations

import math

import manifold3d
import numpy as np
import trimesh

from . import geometry as g
from .registry import Built, register


@register("apple", "radius_m squash stem_length_m", "stem_length_m*1 <= radius_m")
def build_apple(p: dict[str, float]) -> Built:
    """Revolved sphere of radius_m squashed vertically by `squash`, with dimples at both poles
    and a thin stem of stem_length_m rising from the top dimple."""
    R, q, stem = p["radius_m"], p["squash"], p["stem_length_m"]
    phi = np.linspace(0, math.pi, 25)
    r, z = R * np.sin(phi), R * q * (1 - np.cos(phi))
    z += np.where(phi < math.pi / 2, 0.2, -0.3) * R * q * np.exp(-((r / (0.35 * R)) ** 2))  # pole dimples
    top = z[-1]
    stalk = g.cylinder(0.06 * R, (0, 0, top - 0.1 * R), (0, 0, top + stem), 8)
    visual = g.union([g.revolve(np.column_stack([r, z])), stalk])
    return g.finish(visual, [g.hull(visual.vertices)])


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
    rings = g.tube_rings(path, radii, np.array([0.0, 0.0, 1.0]), 16, ridges=5)
    parts = [g.hull(rings[i : i + 8].reshape(-1, 3)) for i in (0, 7, 14, 21)]
    return g.finish(g.tube(rings, path), parts)


def _peel(mesh: trimesh.Trimesh, depth: float, centre: tuple[float, float, float], floor: float) -> trimesh.Trimesh:
    """Dimpled citrus peel: move each vertex above `floor` along its direction from `centre` by
    a smooth criss-cross pattern `depth` deep (deterministic, so no random draws); the flat
    resting patch below `floor` stays flat."""
    v = mesh.vertices - centre
    r = np.linalg.norm(v, axis=1, keepdims=True)
    theta, phi = np.arctan2(v[:, 1], v[:, 0]), np.arccos(np.clip(v[:, 2] / r[:, 0], -1, 1))
    bumps = np.cos(17 * theta + 9 * phi) * np.cos(13 * theta - 11 * phi) * (mesh.vertices[:, 2] > floor)
    return trimesh.Trimesh(centre + v * (1 + depth * bumps[:, None] / r), mesh.faces)


def _citrus_arc(R: float, q: float, flat: float, n: int) -> np.ndarray:
    """(r, z) points of a sphere of radius R squashed by q, from the edge of a flat resting patch
    (`flat` of the way round from the bottom pole, in half-turns) to the top pole."""
    phi = np.linspace(flat * math.pi, math.pi, n)
    arc = np.column_stack([R * np.sin(phi), R * q * (1 - np.cos(phi))])
    arc[-1, 0] = 0.0
    return arc


@register("orange", "radius_m squash", "squash*1 <= 1")
def build_orange(p: dict[str, float]) -> Built:
    """Orange of radius_m, its height squashed by `squash`: a dimpled peel, a flat navel
    underneath so it stays put, and a small stalk scar with sepals on top. One hull."""
    R, q = p["radius_m"], p["squash"]
    arc = _citrus_arc(R, q, 0.12, 22)
    body = _peel(g.revolve([(0, arc[0, 1]), *arc], 40), 0.012 * R, (0, 0, R * q), arc[0, 1] + 0.01 * R)
    top = float(body.vertices[:, 2].max())
    angles = np.linspace(0, 2 * math.pi, 5, endpoint=False)
    sepals = [g.rotated(g.ellipsoid((0.09 * R, 0, top), (0.08 * R, 0.035 * R, 0.02 * R), 1), a, g.Z) for a in angles]
    stalk = g.cylinder(0.05 * R, (0, 0, top - 0.05 * R), (0, 0, top + 0.06 * R), 8)
    visual = g.union([body, *sepals, stalk])
    return g.finish(visual, [g.hull(visual.vertices)])


@register("lemon", "length_m radius_m", "radius_m*2.2 <= length_m")
def build_lemon(p: dict[str, float]) -> Built:
    """Lemon lying on its side: a dimpled ellipsoid radius_m round and length_m from tip to tip
    along x, with a nipple at each end (+x is the flower end) and a small flat patch beneath
    so it does not roll. One hull."""
    L, R = p["length_m"], p["radius_m"]
    a = L / 2 - 0.09 * L  # half length of the body, without the nipples
    t = np.linspace(-1, 1, 31)
    body_r = R * np.sqrt(np.clip(1 - (t * L / 2 / a) ** 2, 0, 1)) ** 0.9
    u = np.clip((np.abs(t) * L / 2 - 0.9 * a) / (L / 2 - 0.9 * a), 0, 1)
    r = np.maximum(body_r, 0.3 * R * (1 - u) ** 0.8)  # a pointed nipple grows out of each end
    r[0] = r[-1] = 0.0
    lemon = g.rotated(g.revolve(np.column_stack([r, t * L / 2]), 32), math.pi / 2, g.Y)  # long axis along x
    visual = g.cut_below(_peel(lemon, 0.006 * R, (0, 0, 0), -np.inf), -0.97 * R)  # the flat patch it rests on
    return g.finish(visual, [g.hull(visual.vertices)])


@register("bread", "length_m width_m height_m", "width_m*1.2 <= length_m", "height_m*0.9 <= width_m")
def build_bread(p: dict[str, float]) -> Built:
    """Loaf of bread length_m (along x) by width_m by height_m: a flat-bottomed body under a
    domed, slightly overhanging crust scored with three diagonal slashes. One hull."""
    L, W, H = p["length_m"], p["width_m"], p["height_m"]
    body = g.rounded_block((-L / 2 + 0.01, -W / 2 + 0.004, 0), (L / 2 - 0.01, W / 2 - 0.004, 0.6 * H), 0.25 * W)
    dome = g.difference(g.ellipsoid((0, 0, 0.5 * H), (L / 2, W / 2, 0.5 * H), 3), g.box((-L, -W, 0), (L, W, 0.42 * H)))
    loaf = g.union([body, dome])
    slashes = []
    for x in (-0.26 * L, 0.0, 0.26 * L):
        top = 0.5 * H + 0.5 * H * math.sqrt(max(0.0, 1 - (2 * x / L) ** 2))
        cut = g.box((-0.004, -0.36 * W, -0.012), (0.004, 0.36 * W, 0.02))
        slashes.append(g.moved(g.rotated(cut, math.radians(35), g.Z), (x, 0, top)))
    visual = g.difference(loaf, *slashes)
    return g.finish(visual, [g.hull(loaf.vertices)])


@register("cake", "radius_m height_m", "height_m*0.8 <= radius_m")
def build_cake(p: dict[str, float]) -> Built:
    """Round cake of radius_m and height_m with a ring of piped frosting on the top edge, a
    cherry in the middle, and a slice cut out on +x (its cut side). One hull."""
    R, H = p["radius_m"], p["height_m"]
    e = 0.08 * H
    body = g.revolve([(0, 0), (R, 0), (R, H - e), *g.arc(R - e, H - e, e, 0, math.pi / 2, 4)[1:], (0, H)], 48)
    blobs = [
        g.ellipsoid(((R - 0.09 * R) * math.cos(a), (R - 0.09 * R) * math.sin(a), H), (0.075 * R,) * 2 + (0.06 * R,), 1)
        for a in np.linspace(0, 2 * math.pi, 16, endpoint=False)
    ]
    cherry = g.ellipsoid((0, 0, H + 0.07 * R), (0.09 * R,) * 3, 2)
    whole = g.union([body, *blobs, cherry])
    half = math.radians(25)
    wedge = g.extrude(
        [np.array([(0.3 * R, 0), (2 * R, -2 * R * math.tan(half)), (2 * R, 2 * R * math.tan(half))])], -0.01, 2 * H
    )
    visual = g.difference(whole, wedge)
    return g.finish(visual, [g.hull(visual.vertices)])


@register("donut", "radius_m thickness_m", "thickness_m*1.4 <= radius_m")
def build_donut(p: dict[str, float]) -> Built:
    """Ring doughnut lying flat: radius_m to the outside, thickness_m tall, with a layer of
    icing over the top half whose edge makes a step, and a flat underside. One hull."""
    R, t = p["radius_m"], p["thickness_m"]
    r = t / 2
    dough = g.circle(R - r, 0.0, r, 28) * (1.0, 0.9)
    icing = g.circle(R - 1.07 * r - 0.0004, 0.0, 1.07 * r, 28) * (1.0, 0.9)
    section = manifold3d.CrossSection([dough]) + (
        manifold3d.CrossSection([icing]) ^ manifold3d.CrossSection([g.rect(0, 0.1 * r, R, r)])
    )
    section = section ^ manifold3d.CrossSection([g.rect(0, -0.8 * r, R, r)])  # flat where it rests
    visual = g.from_manifold(section.revolve(circular_segments=40))
    return g.finish(visual, [g.hull(visual.vertices)])
