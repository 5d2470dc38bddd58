"""Touching and separated: physical contact after settling, or a clear gap."""

from __future__ import annotations

import cv2
import numpy as np

from .facts import ObjectFacts, ViewFacts
from .masks import box_of, cached_boxes
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
        return False if not _meet_in_picture(v, a, b) else None
    return None


def _meet_in_picture(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> bool:
    """Whether the two objects' pixels come within IMAGE_GAP_SHARE of the image width of each
    other (False where either has none, or the view has no segmentation)."""
    if v.seg is None:
        return False
    boxes = cached_boxes(v)
    box_a, box_b = box_of(boxes, a.object_id), box_of(boxes, b.object_id)
    if box_a is None or box_b is None:
        return False
    reach = max(1, int(round(IMAGE_GAP_SHARE * v.seg.shape[1])))
    rows = slice(max(box_a[0].start - reach, box_b[0].start), min(box_a[0].stop + reach, box_b[0].stop))
    cols = slice(max(box_a[1].start - reach, box_b[1].start), min(box_a[1].stop + reach, box_b[1].stop))
    if rows.start >= rows.stop or cols.start >= cols.stop:
        return False  # b's box lies beyond a's box grown by the reach
    # a's pixels grown by the reach (a square: within reach both ways), over b's part of the window
    grown = slice(max(rows.start - reach, 0), rows.stop + reach), slice(max(cols.start - reach, 0), cols.stop + reach)
    near_a = cv2.dilate((v.seg[grown] == a.object_id).view(np.uint8), np.ones((2 * reach + 1,) * 2, np.uint8))
    inner = near_a[rows.start - grown[0].start:rows.stop - grown[0].start, cols.start - grown[1].start:cols.stop - grown[1].start]
    return bool(np.any(inner.view(bool) & (v.seg[rows, cols] == b.object_id)))


@predicate("separated", family="touch_far_from", arity=2, frame="world", inverse="separated", symmetric=True)
def separated(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A and B are clearly apart: the negation of ``touching`` with the same undecided band."""
    verdict = touching(v, a, b)
    return None if verdict is None else not verdict
