"""Touching and separated: physical contact after settling, or a clear gap."""

from __future__ import annotations

import cv2
import numpy as np

from .facts import ObjectFacts, ViewFacts
from .masks import box_of, cached_boxes, padded
from .registry import Verdict, predicate

SEPARATED_GAP_M = 0.02  # a ground gap wider than this between footprints is clearly apart
# "Apart" needs the gap in the picture too: masks closer than this share of the image width meet
# there. A cake in front of a book 8.3 cm behind it hid the gap, and its rim sat on the book's
# edge in the image (annotator, read 32: "is the red book not touching the cake?" yes).
IMAGE_GAP_SHARE = 0.005


@predicate("touching", family="touch_far_from", arity=2, frame="world", inverse="touching", symmetric=True)
def touching(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """The physics engine reports contact between A and B in the settled scene.

    True: a contact pair (penetration or gap < 2 mm). False: no contact, the
    oriented footprints more than 2 cm apart on the ground (footprint gap is
    a lower bound of the true gap, so this never misses a contact), and their
    pixels apart in the picture (IMAGE_GAP_SHARE). Undecided otherwise (close
    without contact, e.g. a cup hovering over a plate's rim; or a gap hidden
    behind the nearer one).
    """
    if (min(a.object_id, b.object_id), max(a.object_id, b.object_id)) in v.contacts:
        return True
    if v.footprint_gap(a, b) > SEPARATED_GAP_M:
        return None if _meet_in_picture(v, a, b) else False
    return None


@predicate("separated", family="touch_far_from", arity=2, frame="world", inverse="separated", symmetric=True)
def separated(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A and B are clearly apart: the negation of ``touching`` with the same undecided band."""
    verdict = touching(v, a, b)
    return None if verdict is None else not verdict


def _meet_in_picture(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> bool:
    """Whether some pixel of B lies within IMAGE_GAP_SHARE of the image width of A's pixels, both
    ways (False where either has none)."""
    boxes = cached_boxes(v)
    box_a, box_b = box_of(boxes, a.object_id), box_of(boxes, b.object_id)
    if box_a is None or box_b is None:
        return False
    reach = max(1, int(round(IMAGE_GAP_SHARE * v.seg.shape[1])))
    window = padded(box_a, reach, v.seg.shape)  # every pixel that near A
    if any(wb.stop <= w.start or wb.start >= w.stop for wb, w in zip(box_b, window)):
        return False
    return bool(np.any(_near(v, a, window, reach) & (v.seg[window] == b.object_id)))


def _near(v: ViewFacts, a: ObjectFacts, window: tuple[slice, slice], reach: int) -> np.ndarray:
    """Bool over ``window``: the pixels within ``reach`` of A's (memoised per view and object:
    every pair with A asks the same dilation)."""
    key = ("near_pixels", a.object_id)
    if key not in v.cache:
        mine = (v.seg[window] == a.object_id).view(np.uint8)
        v.cache[key] = cv2.dilate(mine, np.ones((2 * reach + 1,) * 2, np.uint8)).view(bool)
    return v.cache[key]
