"""Per-object pixels of a segmentation, found inside each object's bounding box.

A 960x540 frame has half a million pixels and an object a few thousand: comparing and
scanning the whole frame once per object (and again per question) cost more than the
relations themselves. One ``find_objects`` pass gives every object's box; work then
stays inside it. Results equal the whole-frame versions, in the same (row-major) order.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

Box = tuple[slice, slice]


def object_boxes(seg: np.ndarray) -> list[Box | None]:
    """Index = object id: the (rows, cols) slices bounding its pixels, or None if it has none."""
    return ndimage.find_objects(seg + 1)  # label id + 1; the background (-1) becomes 0, unlabelled


BOXES_KEY = ("boxes",)  # where a ViewFacts' cache keeps its segmentation's object boxes


def cached_boxes(view) -> list[Box | None]:
    """``object_boxes`` of a ViewFacts' segmentation, memoised in its cache."""
    if BOXES_KEY not in view.cache:
        view.cache[BOXES_KEY] = object_boxes(view.seg)
    return view.cache[BOXES_KEY]


def box_of(boxes: list[Box | None], object_id: int) -> Box | None:
    return boxes[object_id] if 0 <= object_id < len(boxes) else None


def object_pixels(seg: np.ndarray, boxes: list[Box | None], object_id: int) -> tuple[np.ndarray, np.ndarray, Box | None]:
    """(rows, cols) of the object's pixels in frame coordinates, and its box."""
    box = box_of(boxes, object_id)
    if box is None:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty, None
    rows, cols = np.nonzero(seg[box] == object_id)
    return rows + box[0].start, cols + box[1].start, box


def padded(box: Box, pad: int, shape: tuple[int, int]) -> Box:
    """The box grown by ``pad`` pixels on every side, clipped to the frame."""
    return tuple(slice(max(s.start - pad, 0), min(s.stop + pad, n)) for s, n in zip(box, shape))  # type: ignore[return-value]
