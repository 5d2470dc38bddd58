"""Viewer-frame and camera-depth predicates: left/right, front/behind, between, closer.

Margins grow with object size: two large objects whose centres differ by 3 cm
overlap so much in the view that "left of" is no longer a fair thing to ask.
"""

from __future__ import annotations

import numpy as np

from .facts import ObjectFacts, ViewFacts
from .registry import Verdict, compare, predicate

MIN_MARGIN_M = 0.03  # centres closer than this along an axis are a near-tie
SIZE_MARGIN = 0.25  # ...and so are centres closer than this share of the pair's mean extent
DEPTH_MARGIN_M = 0.03
DEPTH_MARGIN_REL = 0.05  # share of the nearer object's depth
BETWEEN_MIN_GAP_M = 0.10  # anchors closer than this enclose no corridor worth naming
BETWEEN_T = (0.2, 0.8)  # where along the anchor segment the subject must sit (fraction)
BETWEEN_OUTSIDE_M = 0.05  # clearly outside the corridor beyond this lateral slack


def axis_margin(a: ObjectFacts, b: ObjectFacts, axis: np.ndarray) -> float:
    return max(MIN_MARGIN_M, SIZE_MARGIN * (a.extent_along(axis) + b.extent_along(axis)) / 2)


def depth_margin(a: ObjectFacts, b: ObjectFacts) -> float:
    return max(DEPTH_MARGIN_M, DEPTH_MARGIN_REL * min(a.depth_m, b.depth_m))


@predicate("left_of", family="left_right", arity=2, frame="viewer", inverse="right_of")
def left_of(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A's centre lies left of B's along the viewer's right axis (ground-projected camera x).

    Margin: max(3 cm, 25 % of the pair's mean extent along that axis).
    """
    return compare(b.lateral_m - a.lateral_m, axis_margin(a, b, v.right_axis))


@predicate("right_of", family="left_right", arity=2, frame="viewer", inverse="left_of")
def right_of(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A's centre lies right of B's along the viewer's right axis; margin as left_of."""
    return compare(a.lateral_m - b.lateral_m, axis_margin(a, b, v.right_axis))


@predicate("in_front_of", family="front_behind", arity=2, frame="viewer", inverse="behind")
def in_front_of(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A's centre is nearer the viewer than B's along the ground-projected forward axis.

    Margin: max(3 cm, 25 % of the pair's mean extent along that axis).
    """
    return compare(b.forward_m - a.forward_m, axis_margin(a, b, v.forward_axis))


@predicate("behind", family="front_behind", arity=2, frame="viewer", inverse="in_front_of")
def behind(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A's centre is farther from the viewer than B's along the forward axis; margin as in_front_of."""
    return compare(a.forward_m - b.forward_m, axis_margin(a, b, v.forward_axis))


@predicate("closer_to_camera", family="depth", arity=2, frame="camera")
def closer_to_camera(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A's visible surface is nearer the camera than B's (median depth over the visible mask).

    Margin: max(3 cm, 5 % of the nearer depth). Its converse, "farther from the
    camera than", is this predicate with the objects swapped.
    """
    if not (np.isfinite(a.depth_m) and np.isfinite(b.depth_m)):
        return None
    return compare(b.depth_m - a.depth_m, depth_margin(a, b))


@predicate("between", family="between", arity=3, frame="world")
def between(v: ViewFacts, a: ObjectFacts, b: ObjectFacts, c: ObjectFacts) -> Verdict:
    """A lies in the ground-plane corridor joining B and C, on the same level as both.

    With t the position of A's centre along the segment B->C (0 at B, 1 at C) and
    d its distance from that line: True when 0.2 <= t <= 0.8 and d is within half
    of the wider anchor's narrow footprint side; False when t < 0, t > 1 or d
    exceeds that by 5 cm; undecided otherwise, and when B and C are < 10 cm apart.
    False when the three rest on different levels (the table top, a shelf board:
    what they stand on, followed down through stacks), as on a shelf a bear on the
    top board is not "between" two things on the board below whatever the plan view.
    """
    if v.on_other_levels(a, b, c):
        return False
    p, q, r = (o.center_world_m[:2] for o in (a, b, c))
    seg = r - q
    length = float(np.linalg.norm(seg))
    if length < BETWEEN_MIN_GAP_M:
        return None
    t = float((p - q) @ seg) / length**2
    d = abs(float(seg[0] * (p - q)[1] - seg[1] * (p - q)[0])) / length
    half_width = 0.5 * max(b.footprint_m.min(), c.footprint_m.min())
    if BETWEEN_T[0] <= t <= BETWEEN_T[1] and d <= half_width:
        return True
    if t < 0 or t > 1 or d > half_width + BETWEEN_OUTSIDE_M:
        return False
    return None


IMAGE_ROW_MARGIN = 0.04  # share of the image height between mask centroids


@predicate("higher_in_image", family="image_above_below", arity=2, frame="image", inverse="lower_in_image")
def higher_in_image(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A's visible-mask centroid lies higher in the image (smaller row) than B's.

    Margin: 4 % of the image height. Undecided when either object is unseen.
    """
    if a.centroid_px is None or b.centroid_px is None:
        return None
    return compare(b.centroid_px[1] - a.centroid_px[1], IMAGE_ROW_MARGIN * v.height)


@predicate("lower_in_image", family="image_above_below", arity=2, frame="image", inverse="higher_in_image")
def lower_in_image(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A's visible-mask centroid lies lower in the image (larger row) than B's; margin as higher_in_image."""
    if a.centroid_px is None or b.centroid_px is None:
        return None
    return compare(a.centroid_px[1] - b.centroid_px[1], IMAGE_ROW_MARGIN * v.height)
