"""Sizes, distances and camera angles: comparatives and metric measures."""

from __future__ import annotations

import numpy as np

from .facts import ObjectFacts, ViewFacts
from .registry import Quantity, Verdict, compare, predicate

HEIGHT_MARGIN = (0.01, 0.10)  # (absolute m, share of the taller): closer heights are a near-tie
VOLUME_MARGIN = 0.20  # share of the larger volume
WIDTH_MARGIN = (0.01, 0.10)  # (absolute m, share of the wider)
NEAR_GAP = (0.05, 0.5)  # near: footprint gap <= max(5 cm, 0.5 x mean footprint size)
FAR_GAP = (0.25, 2.0)  # far: footprint gap >= max(25 cm, 2 x mean footprint size)
CENTRED_DEG = 2.0  # within this, the camera needs no turn


def _relative(diff: float, scale: float, margin: tuple[float, float]) -> Verdict:
    return compare(diff, max(margin[0], margin[1] * scale))


@predicate("taller_than", family="tall_short", arity=2, frame="world", inverse="shorter_than")
def taller_than(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A's height along gravity (world box) exceeds B's by max(1 cm, 10 % of the taller)."""
    return _relative(a.height_m - b.height_m, max(a.height_m, b.height_m), HEIGHT_MARGIN)


@predicate("shorter_than", family="tall_short", arity=2, frame="world", inverse="taller_than")
def shorter_than(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """B's height exceeds A's by max(1 cm, 10 % of the taller)."""
    return taller_than(v, b, a)


@predicate("bigger_than", family="big_small", arity=2, frame="world", inverse="smaller_than")
def bigger_than(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A's volume (enclosed by its mesh, so a bowl counts its material, not its hollow) exceeds
    B's by 20 % of the larger volume."""
    return compare(a.volume_m3 - b.volume_m3, VOLUME_MARGIN * max(a.volume_m3, b.volume_m3))


@predicate("smaller_than", family="big_small", arity=2, frame="world", inverse="bigger_than")
def smaller_than(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """B's volume exceeds A's by 20 % of the larger volume."""
    return bigger_than(v, b, a)


@predicate("wider_than", family="wide_thin", arity=2, frame="viewer", inverse="thinner_than")
def wider_than(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A's extent along the viewer's right axis exceeds B's by max(1 cm, 10 % of the wider)."""
    wa, wb = a.extent_along(v.right_axis), b.extent_along(v.right_axis)
    return _relative(wa - wb, max(wa, wb), WIDTH_MARGIN)


@predicate("thinner_than", family="wide_thin", arity=2, frame="viewer", inverse="wider_than")
def thinner_than(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """B's extent along the viewer's right axis exceeds A's; margin as wider_than."""
    return wider_than(v, b, a)


def _gap_and_scale(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> tuple[float, float]:
    gap = v.footprint_gap(a, b)
    if v.on_other_levels(a, b):  # a cup under the vase on the board above is not near it
        (a_lo, a_hi), (b_lo, b_hi) = a.aabb_world_m[:, 2], b.aabb_world_m[:, 2]
        lift = max(0.0, float(a_lo - b_hi), float(b_lo - a_hi))
        gap = float(np.hypot(gap, lift))
    scale = (float(a.footprint_m.max()) + float(b.footprint_m.max())) / 2
    return gap, scale


@predicate("near", family="close_far", arity=2, frame="world", inverse="near", symmetric=True)
def near(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """The ground gap between footprints is small for the objects' size.

    True: gap <= max(5 cm, 0.5 x mean footprint size). False: gap >= max(25 cm,
    2 x mean footprint size). Undecided in between. For objects on different levels
    (shelf boards) the gap includes the height between their boxes.
    """
    gap, scale = _gap_and_scale(v, a, b)
    if gap <= max(NEAR_GAP[0], NEAR_GAP[1] * scale):
        return True
    if gap >= max(FAR_GAP[0], FAR_GAP[1] * scale):
        return False
    return None


@predicate("far", family="close_far", arity=2, frame="world", inverse="far", symmetric=True)
def far(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """The negation of ``near`` with the same undecided band."""
    verdict = near(v, a, b)
    return None if verdict is None else not verdict


@predicate("distance_between", family="distance", arity=2, frame="world", inverse="distance_between",
           kind="measure", symmetric=True)
def distance_between(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Quantity:
    """Metric distance between the two objects' world box centres, in metres."""
    return Quantity(float(np.linalg.norm(a.center_world_m - b.center_world_m)), "m")


def _ray(v: ViewFacts, o: ObjectFacts) -> np.ndarray | None:
    """Camera-frame unit ray through the object's visible-mask centroid."""
    if o.centroid_px is None or v.K is None:
        return None
    ray = np.linalg.inv(v.K) @ np.array([o.centroid_px[0], o.centroid_px[1], 1.0])
    return ray / np.linalg.norm(ray)


@predicate("angle_between", family="angle", arity=2, frame="camera", inverse="angle_between",
           kind="measure", symmetric=True)
def angle_between(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Quantity | None:
    """Angle subtended at the camera by the two objects' visible-mask centroids, in degrees."""
    ra, rb = _ray(v, a), _ray(v, b)
    if ra is None or rb is None:
        return None
    return Quantity(float(np.degrees(np.arccos(np.clip(ra @ rb, -1.0, 1.0)))), "deg")


@predicate("rotate_horizontal", family="rotation", arity=1, frame="camera", kind="measure")
def rotate_horizontal(v: ViewFacts, a: ObjectFacts) -> Quantity | None:
    """Yaw the camera must turn to centre the object's visible mask, degrees; positive = turn right.

    None when already within 2 degrees of centre (no direction to ask about).
    """
    if a.centroid_px is None or v.K is None:
        return None
    yaw = float(np.degrees(np.arctan2(a.centroid_px[0] - v.K[0, 2], v.K[0, 0])))
    return None if abs(yaw) < CENTRED_DEG else Quantity(yaw, "deg")


@predicate("rotate_vertical", family="rotation", arity=1, frame="camera", kind="measure")
def rotate_vertical(v: ViewFacts, a: ObjectFacts) -> Quantity | None:
    """Pitch the camera must turn to centre the object's visible mask, degrees; positive = tilt up.

    None when already within 2 degrees of centre.
    """
    if a.centroid_px is None or v.K is None:
        return None
    pitch = float(np.degrees(np.arctan2(v.K[1, 2] - a.centroid_px[1], v.K[1, 1])))
    return None if abs(pitch) < CENTRED_DEG else Quantity(pitch, "deg")
