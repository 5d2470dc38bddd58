"""Image-side annotations carried by QA: run-length masks and drawn marks.

Free-space answers keep their region mask (so answers can be scored as in
RefSpatial-Bench: a point inside the mask) as a row-major run-length code.
Visual-choice questions store the marks to draw rather than a second image;
``draw_marks`` renders them identically for exports, audits and loaders.
"""

from __future__ import annotations

import cv2
import numpy as np


def rle_encode(mask: np.ndarray) -> dict:
    """{"size": [H, W], "counts": [...]}: lengths of alternating runs, row-major, starting with False."""
    flat = np.asarray(mask, dtype=bool).ravel()
    change = np.flatnonzero(flat[1:] != flat[:-1]) + 1
    bounds = np.concatenate([[0], change, [flat.size]])
    counts = np.diff(bounds).tolist()
    if flat.size and flat[0]:
        counts = [0] + counts
    return {"size": [int(mask.shape[0]), int(mask.shape[1])], "counts": [int(c) for c in counts]}


def rle_decode(rle: dict) -> np.ndarray:
    h, w = rle["size"]
    values = np.zeros(len(rle["counts"]), dtype=bool)
    values[1::2] = True
    flat = np.repeat(values, rle["counts"])
    if flat.size != h * w:
        raise ValueError(f"run-length code covers {flat.size} pixels, expected {h}x{w}")
    return flat.reshape(h, w)


def draw_marks(rgb: np.ndarray, marks: list[dict]) -> np.ndarray:
    """A copy of the image with each mark's box drawn in its colour (and its label, for numbered marks)."""
    out = np.ascontiguousarray(rgb.copy())
    thickness = max(1, round(min(rgb.shape[:2]) / 180))
    for m in marks:
        x0, y0, x1, y1 = m["box_px"]
        color = tuple(int(c) for c in m["rgb"])
        cv2.rectangle(out, (x0, y0), (x1, y1), color, thickness, lineType=cv2.LINE_AA)
    return out
