"""Small planar and projective geometry used by the predicates.

Footprints are convex polygons on the ground plane given as (N, 2) corner arrays
in counter-clockwise order.
"""

from __future__ import annotations

import numpy as np


def _next(a: np.ndarray) -> np.ndarray:
    """Each corner's successor around the polygon (np.roll(a, -1, axis=0), without its overhead:
    these helpers run tens of thousands of times per scene)."""
    return np.concatenate([a[1:], a[:1]])


def _twice_signed_area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return float(np.dot(x, _next(y)) - np.dot(y, _next(x)))


def polygon_area(poly: np.ndarray) -> float:
    if len(poly) < 3:
        return 0.0
    return 0.5 * abs(_twice_signed_area(poly))


def ccw(poly: np.ndarray) -> np.ndarray:
    """The polygon with counter-clockwise winding."""
    return poly if _twice_signed_area(poly) >= 0 else poly[::-1]


def clip_convex(subject: np.ndarray, clipper: np.ndarray) -> np.ndarray:
    """Intersection of two convex polygons (Sutherland-Hodgman)."""
    out = ccw(subject)
    clip = ccw(clipper)
    for a, b in zip(clip, _next(clip)):
        if len(out) == 0:
            break
        edge = b - a
        side = edge[0] * (out[:, 1] - a[1]) - edge[1] * (out[:, 0] - a[0])  # >= 0: inside (left of edge)
        kept = []
        for i in range(len(out)):
            p, q, sp, sq = out[i], out[(i + 1) % len(out)], side[i], side[(i + 1) % len(out)]
            if sp >= 0:
                kept.append(p)
            if (sp >= 0) != (sq >= 0):
                kept.append(p + (q - p) * (sp / (sp - sq)))
        out = np.array(kept) if kept else np.zeros((0, 2))
    return out


def overlap_share(a: np.ndarray, b: np.ndarray) -> float:
    """Area of a ∩ b as a share of a's area."""
    area = polygon_area(a)
    return polygon_area(clip_convex(a, b)) / area if area > 0 else 0.0


def inside_convex(points: np.ndarray, poly: np.ndarray, grow: float = 0.0) -> np.ndarray:
    """Boolean mask of (N, 2) points inside a convex polygon grown outward by ``grow`` metres."""
    poly = ccw(poly)
    edges = _next(poly) - poly
    normals = np.column_stack([edges[:, 1], -edges[:, 0]]) / np.linalg.norm(edges, axis=1)[:, None]  # outward
    offsets = np.einsum("ij,ij->i", poly, normals)
    return np.all(points @ normals.T - offsets <= grow, axis=1)


def gap_between(a: np.ndarray, b: np.ndarray) -> float:
    """Smallest distance between two convex polygons (0 when they overlap)."""
    boxes_meet = np.all(a.min(0) <= b.max(0)) and np.all(b.min(0) <= a.max(0))
    if boxes_meet and len(clip_convex(a, b)) >= 3:
        return 0.0
    best = np.inf
    for p, q in ((a, b), (b, a)):  # every corner of one against every edge of the other
        s, d = q, _next(q) - q
        t = np.clip(np.einsum("mkj,kj->mk", p[:, None, :] - s[None], d) / np.maximum(np.einsum("kj,kj->k", d, d), 1e-12),
                    0, 1)
        closest = s[None] + t[..., None] * d[None]
        best = min(best, float(np.sqrt(((p[:, None, :] - closest) ** 2).sum(-1)).min()))
    return best


def project(points_world: np.ndarray, K: np.ndarray, T_world_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates (N, 2) and optical-axis depths (N,) of world points, OpenCV camera."""
    p_cam = (points_world - T_world_cam[:3, 3]) @ T_world_cam[:3, :3]
    z = p_cam[:, 2]
    uv = (p_cam @ K.T)[:, :2] / np.where(np.abs(z) < 1e-9, 1e-9, z)[:, None]
    return uv, z
