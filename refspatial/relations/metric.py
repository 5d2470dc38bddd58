"""Sizes, distances and camera angles: comparatives and metric measures."""

from __future__ import annotations

import cv2
import numpy as np

from ..vector import angle_deg, length
from .facts import ObjectFacts, ViewFacts
from .geometry import project, widths
from .registry import Quantity, Verdict, compare, predicate
from .vertical import contained

# A clear margin: a person comparing two heights or widths by eye calls 20 % (or 2 cm) a
# difference worth a word; closer than that is a near-tie, never asked.
HEIGHT_MARGIN = (0.02, 0.20)  # (absolute m, share of the taller)
HEIGHT_SEEN_SHARE = 0.7  # least share of its silhouette an object shows for its height to be judged
VOLUME_MARGIN = 0.20  # share of the larger volume, for both readings of "bigger"
# ...and the eye's reading: how big each looks in the picture, by the area its outline prism
# covers there, must agree beyond this share of the larger (a cake in front looks larger than
# the one at the back that is bigger: annotator).
APPARENT_MARGIN = 0.10
# ...and its longest dimension (longest ground span or height) may not be clearly shorter: a phone
# 16 cm long does not look smaller than a 9 cm jar, whatever the volumes say (annotator).
LONGEST_MARGIN = 0.10
FLAT_SHARE = 0.25  # height against the footprint's shorter side, at most, for a thing lying flat
WIDTH_MARGIN = (0.02, 0.20)  # (absolute m, share of the wider)
RAISED_TOP_M = 0.25  # a support this tall is furniture with a raised top (side table, stool, cabinet)
NEAR_GAP = (0.05, 0.5)  # near: footprint gap <= max(5 cm, 0.5 x mean footprint size)
FAR_GAP = (0.25, 2.0)  # far: footprint gap >= max(25 cm, 2 x mean footprint size)
CENTRED_DEG = 2.0  # within this, the camera needs no turn
PAN_READINGS_DEG = 1.0  # the most a pan to the box centre may differ from one to the footprint's centre
TILT_READINGS_DEG = 2.0  # the most a tilt after a level pan may differ from one after a turn about the camera's own axis


def _relative(diff: float, scale: float, margin: tuple[float, float]) -> Verdict:
    return compare(diff, max(margin[0], margin[1] * scale))


@predicate("taller_than", family="tall_short", arity=2, frame="world", inverse="shorter_than")
def taller_than(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A's height along gravity (world box) exceeds B's by max(2 cm, 20 % of the taller), and
    B's longest dimension is no longer than A's: "shorter" also reads as less long, so an orange
    against a 22 cm screwdriver lying flat is undecided (annotator), and so is a 20 cm
    screwdriver lying flat against an 18 cm wine glass (annotator). Undecided unless both are
    seen at least HEIGHT_SEEN_SHARE whole: a bottle whose neck a shelf board hides looks shorter
    than it is (annotator, read 25)."""
    if min(a.visible_share, b.visible_share) < HEIGHT_SEEN_SHARE:
        return None
    verdict = _relative(a.height_m - b.height_m, max(a.height_m, b.height_m), HEIGHT_MARGIN)
    if verdict is None:
        return None
    taller, other = (a, b) if verdict else (b, a)
    return None if _longest(v, other) > _longest(v, taller) else verdict


@predicate("shorter_than", family="tall_short", arity=2, frame="world", inverse="taller_than")
def shorter_than(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """B's height exceeds A's by max(2 cm, 20 % of the taller)."""
    return taller_than(v, b, a)


@predicate("bigger_than", family="big_small", arity=2, frame="world", inverse="smaller_than")
def bigger_than(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A is bigger than B by every reading of "big": the volume its mesh encloses (a bowl's
    material) and the volume of its box (a bowl with its hollow, as the eye takes it), each
    larger by 20 % of the larger, and it looks bigger in the picture (the area its outline
    prism covers there, larger by 10 % of the larger). A plate against an apple, bigger by one
    reading and smaller by another, is undecided and never asked; so is a big cake at the back
    that looks smaller than a small one in front, and a jar against a phone whose length is
    clearly longer than anything of the jar's (its longest dimension, 10 % margin, may not
    contradict). Two flat things (boards, plates, books on their backs) are compared by their
    faces too: the ground outline's area must be larger by the same 20 %."""
    enclosed = compare(a.volume_m3 - b.volume_m3, VOLUME_MARGIN * max(a.volume_m3, b.volume_m3))
    box = compare(a.box_volume_m3 - b.box_volume_m3, VOLUME_MARGIN * max(a.box_volume_m3, b.box_volume_m3))
    sa, sb = apparent_area_px(v, a), apparent_area_px(v, b)
    looks = compare(sa - sb, APPARENT_MARGIN * max(sa, sb))
    if enclosed is None or not enclosed == box == looks:
        return None
    if _flat(a) and _flat(b):
        # Flat things are as big as their face: a cutting board thicker than another but with the
        # smaller face (0.069 against 0.073 m^2) was "larger" by volume only (annotator, read 36).
        fa, fb = a.ground_area_m2, b.ground_area_m2
        if compare(fa - fb, VOLUME_MARGIN * max(fa, fb)) is not enclosed:
            return None
    la, lb = _longest(v, a), _longest(v, b)
    longest = compare(la - lb, LONGEST_MARGIN * max(la, lb))
    return None if longest is (not enclosed) else enclosed  # the longest may be a tie, not the opposite


def _flat(o: ObjectFacts) -> bool:
    """Lying flat: no taller than FLAT_SHARE of its footprint's shorter side (a plate, a board,
    a book on its back)."""
    sides = o.footprint_sides_m
    return sides is not None and o.height_m <= FLAT_SHARE * sides[0]


def _longest(v: ViewFacts, o: ObjectFacts) -> float:
    """The object's longest dimension: its longest ground span or its height."""
    return max(_plan_widths(v, o)[1], o.height_m)


def apparent_area_px(v: ViewFacts, o: ObjectFacts) -> float:
    """Pixels the object's outline prism (its ground outline from its bottom to its top) covers
    in the picture, occlusion aside: how big it looks from here (memoised per view)."""
    key = ("apparent_px", o.object_id)
    if key not in v.cache:
        ring = o.ground_outline
        (_, _, z0), (_, _, z1) = o.aabb_world_m
        # The ring at the bottom, then at the top (filled in place: np.c_'s indexing machinery took
        # 50 us of the 70 a call).
        n = len(ring)
        prism = np.empty((2 * n, 3))
        prism[:n, :2] = prism[n:, :2] = ring
        prism[:n, 2], prism[n:, 2] = z0, z1
        uv, z = project(prism, v.K, v.T_world_cam)
        v.cache[key] = float(cv2.contourArea(cv2.convexHull(uv.astype(np.float32)))) if np.all(z > 0.01) else 0.0
    return v.cache[key]


@predicate("smaller_than", family="big_small", arity=2, frame="world", inverse="bigger_than")
def smaller_than(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """B is bigger than A by both readings (see bigger_than)."""
    return bigger_than(v, b, a)


def _plan_widths(v: ViewFacts, o: ObjectFacts) -> tuple[float, float]:
    """The object's own narrowest and widest horizontal extents (memoised per view)."""
    key = ("plan_widths", o.object_id)
    if key not in v.cache:
        v.cache[key] = widths(o.ground_outline)
    return v.cache[key]


@predicate("wider_than", family="wide_thin", arity=2, frame="viewer", inverse="thinner_than")
def wider_than(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A is wider than B by every reading of "wide": its extent along the viewer's right axis
    (side to side as seen), its own narrowest horizontal width and its own longest horizontal
    span each exceed B's by max(2 cm, 20 % of the wider). False when B is wider so; undecided
    otherwise. An orange is not "narrower than a fork" lying across the view: the fork is
    longer, but thinner (annotator)."""
    readings = [(a.extent_along(v.right_axis), b.extent_along(v.right_axis)),
                *zip(_plan_widths(v, a), _plan_widths(v, b))]
    verdicts = {_relative(wa - wb, max(wa, wb), WIDTH_MARGIN) for wa, wb in readings}
    return verdicts.pop() if len(verdicts) == 1 else None



@predicate("thinner_than", family="wide_thin", arity=2, frame="viewer", inverse="wider_than")
def thinner_than(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """B is wider than A by every reading (see wider_than); asked as "narrower"."""
    return wider_than(v, b, a)


def _gap_and_scale(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> tuple[float, float]:
    """The pair's gap and mean footprint size (memoised per pair, either order: near, far and the
    distance between them ask it of each; every term is symmetric, the sum too)."""
    key = ("gap_and_scale", *sorted((a.object_id, b.object_id)))
    if key not in v.cache:
        v.cache[key] = _worked_out_gap_and_scale(v, a, b)
    return v.cache[key]


def _worked_out_gap_and_scale(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> tuple[float, float]:
    gap = v.footprint_gap(a, b)
    # The height between their boxes counts wherever one is wholly above the other: a cup under
    # the vase on the board above is not near it, and a bowl on the floor is 1.08 m from a pen
    # holder on the coffee table, not the 1.03 m between their outlines on the ground (annotator).
    (a_lo, a_hi), (b_lo, b_hi) = a.aabb_world_m[:, 2], b.aabb_world_m[:, 2]
    lift = max(0.0, float(a_lo - b_hi), float(b_lo - a_hi))
    if lift > 0.0:
        gap = float(np.hypot(gap, lift))
    scale = (max(a.footprint_m.tolist()) + max(b.footprint_m.tolist())) / 2  # exact maxima, as numpy's
    return gap, scale


@predicate("near", family="close_far", arity=2, frame="world", inverse="near", symmetric=True)
def near(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """The ground gap between footprints is small for the objects' size.

    True: gap <= max(5 cm, 0.5 x mean footprint size). False: gap >= max(25 cm,
    2 x mean footprint size). Undecided in between. When one object's box lies wholly above
    the other's (shelf boards, a coffee table's top and the floor) the gap includes the
    height between them. Undecided when one rests on or in the other: a bottle in a basket
    is in it, not "close to" it.
    """
    if v.stacked(a, b) or contained(v, a, b) is not False or contained(v, b, a) is not False:
        return None
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
def distance_between(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Quantity | None:
    """The gap between the two objects, as a person measures "the distance between" them: the
    shortest distance between them on the ground (between the meshes' own ground outlines,
    so a round apple is round), combined with the height between their boxes when one lies
    wholly above the other, in metres; 0 when they touch.

    Undecided beside furniture with a raised top, unless one is wholly above the other or they
    touch: the shortest distance from a pot on the floor to a side table is to its base (67 cm),
    while the outlines seen from above meet the top's rim (58 cm), 50 cm higher (annotator)."""
    gap, _ = _gap_and_scale(v, a, b)
    if gap > 0.0 and _beside_raised_top(a, b):
        return None
    return Quantity(float(gap), "m")


def _beside_raised_top(a: ObjectFacts, b: ObjectFacts) -> bool:
    """Whether one is furniture with a raised top and the other is level with some of it."""
    (a_lo, a_hi), (b_lo, b_hi) = a.aabb_world_m[:, 2], b.aabb_world_m[:, 2]
    level = a_lo < b_hi and b_lo < a_hi
    return level and any(o.is_support and o.height_m >= RAISED_TOP_M for o in (a, b))


def centre_distance(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Quantity:
    """The distance between the two objects' box centres, in metres (asked only as "between the
    centres of")."""
    return Quantity(length(a.center_world_m - b.center_world_m), "m")


def _ray(v: ViewFacts, o: ObjectFacts) -> np.ndarray | None:
    """Camera-frame unit ray towards the object's centre (its box centre): what "aim at the
    bowl" means, whatever part of it happens to be visible."""
    centre = v.centre_in_camera(o)
    if centre is None or o.centroid_px is None or centre[2] <= 0:
        return None
    return centre / length(centre)


@predicate("angle_between", family="angle", arity=2, frame="camera", inverse="angle_between",
           kind="measure", symmetric=True)
def angle_between(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Quantity | None:
    """Angle at the camera between the rays to the two objects' centres, in degrees."""
    ra, rb = _ray(v, a), _ray(v, b)
    if ra is None or rb is None:
        return None
    return Quantity(angle_deg(ra @ rb), "deg")


@predicate("rotate_horizontal", family="rotation", arity=1, frame="camera", kind="measure")
def rotate_horizontal(v: ViewFacts, a: ObjectFacts) -> Quantity | None:
    """How far the camera must pan to face the object's centre, degrees; positive = turn right.

    A pan turns about the world's vertical, as a pan-tilt head or a robot's base does, so it is
    the angle on the ground between the camera's heading and the direction of the object. The
    camera's own tilted up-axis would give another answer for a camera looking down (28 degrees
    where a level pan needs 37: annotator). None when already within 2 degrees, or unseen, and
    when the object's centre reads two ways a degree or more apart: a frying pan's box centre
    (its handle included) asked 9.8 degrees where its footprint's centre needs 8.3 (annotator,
    read 26).
    """
    ray = _world_ray(v, a)
    if ray is None:
        return None
    yaw = _yaw_deg(v, ray)
    if len(a.ground_centres) > 1 and v.T_world_cam is not None:
        to_footprint = np.array([*a.ground_centres[1], a.center_world_m[2]]) - v.T_world_cam[:3, 3]
        if abs(_yaw_deg(v, to_footprint) - yaw) >= PAN_READINGS_DEG:
            return None
    return None if abs(yaw) < CENTRED_DEG else Quantity(yaw, "deg")


def _yaw_deg(v: ViewFacts, d: np.ndarray) -> float:
    """Angle on the ground from the camera's heading to direction ``d``, degrees; positive = right."""
    return float(np.degrees(np.arctan2(d @ v.right_axis, d @ v.forward_axis)))


@predicate("rotate_vertical", family="rotation", arity=1, frame="camera", kind="measure")
def rotate_vertical(v: ViewFacts, a: ObjectFacts) -> Quantity | None:
    """How far the camera must tilt to face the object's centre once it has panned to it,
    degrees; positive = tilt up: the object's elevation seen from the camera less the camera's
    own pitch. None when already within 2 degrees, or unseen, and when a turn about the camera's
    own tilted up-axis would leave another tilt (differing by more than TILT_READINGS_DEG or in
    direction): "after turning to face the candle" can be read either way, and for a candle at
    the picture's edge, a little below its middle, one reading said 3 degrees up and the other
    1 down (annotator).
    """
    ray = _world_ray(v, a)
    if ray is None:
        return None
    heading = v.T_world_cam[:3, 2]
    pitch = _elevation_deg(ray) - _elevation_deg(heading)
    x, y, z = _ray(v, a)  # the camera's frame: x right, y down, z forward
    own = float(np.degrees(np.arctan2(-y, np.hypot(x, z))))
    if abs(pitch) < CENTRED_DEG or abs(own) < CENTRED_DEG or own * pitch < 0 or abs(own - pitch) > TILT_READINGS_DEG:
        return None
    return Quantity(pitch, "deg")


def _world_ray(v: ViewFacts, o: ObjectFacts) -> np.ndarray | None:
    """World-frame unit ray from the camera towards the object's centre."""
    ray = _ray(v, o)
    return None if ray is None else v.T_world_cam[:3, :3] @ ray


def _elevation_deg(d: np.ndarray) -> float:
    return float(np.degrees(np.arctan2(d[2], np.hypot(d[0], d[1]))))
