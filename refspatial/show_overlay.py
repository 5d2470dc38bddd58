"""What ``refspatial show`` draws over a record's RGB panel, one colour per QA: the target's
outline, answer markers, numbered reasoning-step discs with their labels, objects a
question names, visual-choice boxes and placement regions; and the crop ``--zoom`` uses."""

from __future__ import annotations

import numpy as np

from .show_layout import LABEL_CHARS, LABEL_PX, MARKER_PX, RING_PX, STEP_PX, Layout, ShowError, pt


def zoom_box(seg: np.ndarray, qas: list) -> tuple[float, float, float, float]:
    """The image's aspect, around everything the QAs touch plus 25 % each side, at least a
    quarter of the image wide, and inside it."""
    h, w = seg.shape
    xs: list[float] = []
    ys: list[float] = []
    for _, qa, _ in qas:
        free = free_region_mask(qa, seg.shape)
        rows, cols = np.nonzero(np.isin(seg, _named_ids(qa)) | (False if free is None else free))
        points = qa.get("answer_points", []) + [s["point"] for s in _located(qa)]
        boxes = [m["box_px"] for m in qa.get("marks") or []]
        if rows.size:
            xs, ys = xs + [cols.min(), cols.max() + 1], ys + [rows.min(), rows.max() + 1]
        xs += [*(x * w for x, _ in points), *(b[i] for b in boxes for i in (0, 2))]
        ys += [*(y * h for _, y in points), *(b[i] for b in boxes for i in (1, 3))]
    if not xs:
        return 0.0, 0.0, float(w), float(h)
    cw = min(max(1.5 * (max(xs) - min(xs)), 1.5 * (max(ys) - min(ys)) * w / h, w / 4), w)
    ch = cw * h / w
    x0 = float(np.clip((max(xs) + min(xs) - cw) / 2, 0, w - cw))
    y0 = float(np.clip((max(ys) + min(ys) - ch) / 2, 0, h - ch))
    return x0, y0, float(cw), float(ch)


def _named_ids(qa: dict) -> list[int]:
    """The target and every object the program picked out in this view."""
    ids = [n["result"] for n in qa.get("steps", []) if n.get("op") == "unique" and n.get("view", "self") == "self"]
    return list(dict.fromkeys(([qa["target_id"]] if qa.get("target_id") is not None else []) + ids))


def with_marks(rgb: np.ndarray, qas: list) -> np.ndarray:
    """The boxes visual-choice questions ask about, drawn as the model is shown them."""
    marks = [m for _, qa, _ in qas for m in qa.get("marks") or []]
    if not marks:
        return rgb
    from .annotate import draw_marks

    return draw_marks(rgb, marks)


def _outline(ax, mask: np.ndarray, color: str, grow: int = 0, lw: float = 2.0, holes: bool = False,
             **style) -> None:
    """Mask contour in the QA colour over a white halo, so it reads on dark and light objects.
    Outlined, not tinted: a tint would change the colour words the questions rely on."""
    import cv2
    from matplotlib.patches import Polygon

    mask = mask.astype(np.uint8)
    if grow:
        mask = cv2.dilate(mask, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * grow + 1,) * 2))
    mode = cv2.RETR_LIST if holes else cv2.RETR_EXTERNAL
    for c in cv2.findContours(mask, mode, cv2.CHAIN_APPROX_SIMPLE)[0]:
        xy = c[:, 0, :] + 0.5  # contour pixels -> their centres in data coordinates
        if len(xy) >= 2:
            ax.add_patch(Polygon(xy, closed=True, fill=False, ec="white", lw=lw + 2, zorder=2))
            ax.add_patch(Polygon(xy, closed=True, ec=color, lw=lw, zorder=2, **{"fill": False, **style}))


def inside_point(mask: np.ndarray) -> tuple[float, float] | None:
    """The mask pixel farthest from its border: a label there stays on concave shapes too."""
    import cv2

    if not mask.any():
        return None
    dist = cv2.distanceTransform(np.pad(mask, 1).astype(np.uint8), cv2.DIST_L2, 3)[1:-1, 1:-1]
    r, c = np.unravel_index(int(np.argmax(dist)), dist.shape)
    return c + 0.5, r + 0.5


def _place(boxes: list, x: float, y: float, text: str, width: float, height: float) -> tuple[float, float]:
    """Greedy label placement in panel pixels: of ten spots beside the anchor, the first inside
    the panel that overlaps no box in ``boxes`` (markers, labels), else the least overlapping."""
    tw, th = len(text) * LABEL_PX * 0.6 + 8, LABEL_PX * 1.7
    best = None
    for n, (k, side) in enumerate((k, side) for k in (0, -1, 1, -2, 2) for side in (1, -1)):
        left = x + STEP_PX * 0.7 if side > 0 else x - STEP_PX * 0.7 - tw
        box = (left, y + (k - 0.5) * th, left + tw, y + (k + 0.5) * th)
        inside = box[0] >= 0 and box[1] >= 0 and box[2] <= width and box[3] <= height
        overlap = sum(max(0.0, min(box[2], b[2]) - max(box[0], b[0])) * max(0.0, min(box[3], b[3]) - max(box[1], b[1]))
                      for b in boxes)
        best = min(best or (np.inf, n, box), (overlap + (0 if inside else 1e9), n, box))
    boxes.append(best[2])
    return (best[2][0] + best[2][2]) / 2, (best[2][1] + best[2][3]) / 2


def annotate(ax, seg: np.ndarray, qas: list, lay: Layout) -> None:
    """Outlines and step discs first, answer markers above them, labels placed last around all."""
    h, w = seg.shape
    boxes: list[tuple[float, ...]] = []  # in panel pixels: what labels must not cover

    def block(x: float, y: float, size: float) -> None:
        px, py = lay.panel_xy(x, y)
        boxes.append((px - size / 2, py - size / 2, px + size / 2, py + size / 2))

    labels: list[tuple[float, float, str, str]] = []
    for k, (_, qa, color) in enumerate(qas):
        labels += _draw_qa(ax, seg, qa, color, int(np.ceil(RING_PX * k / lay.scale)), lay.scale, block)
    for _, qa, color in qas:
        for x, y in qa.get("answer_points", []):
            ax.plot(x * w, y * h, "o", ms=pt(MARKER_PX), mfc=color, mec="white", mew=1.5, zorder=6)
            block(x * w, y * h, MARKER_PX)
    for x, y, text, color in labels:
        cx, cy = _place(boxes, *lay.panel_xy(x, y), text, *lay.main[2:])
        xy = (lay.crop[0] + cx / lay.scale, lay.crop[1] + cy / lay.scale)
        ax.annotate(text, (x, y), xy, fontsize=pt(LABEL_PX), ha="center", va="center", zorder=4,
                    bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": color, "alpha": 0.85, "lw": 1.2},
                    arrowprops={"arrowstyle": "-", "color": color, "lw": 1.2, "shrinkA": 0, "shrinkB": 4})


def _draw_qa(ax, seg: np.ndarray, qa: dict, color: str, grow: int, scale: float, block) -> list:
    """One QA's outlines (``grow`` record pixels out, so several QAs on one object nest) and
    step discs; returns its labels (x, y, text, colour) to place."""
    h, w = seg.shape
    if qa.get("target_id") is not None:
        _outline(ax, seg == qa["target_id"], color, grow, lw=2.5)
    free = free_region_mask(qa, seg.shape)
    if free is not None:  # dashed outline (holes too: obstacles inside) over stripes ~8 output px apart
        from matplotlib.colors import to_rgba

        rows, cols = np.indices(seg.shape)
        stripes = np.zeros((h, w, 4))
        stripes[free & (((rows + cols) // max(1, round(8 / scale))) % 2 == 0)] = to_rgba(color, 0.5)
        ax.imshow(stripes, extent=(0, w, h, 0), interpolation="nearest", zorder=1)
        _outline(ax, free, color, holes=True, ls="--")
    located = _located(qa)
    labels = []
    for i, step in enumerate(located, 1):
        x, y = step["point"][0] * w, step["point"][1] * h
        ax.plot(x, y, "o", ms=pt(STEP_PX), mfc="white", mec=color, mew=2, zorder=5)
        ax.text(x, y, str(i), fontsize=pt(LABEL_PX - 2), ha="center", va="center", fontweight="bold", zorder=5)
        block(x, y, STEP_PX)
        labels.append((x, y, _short(step["text"]), color))
    if not located:  # no trace in this view: name the objects the program picked
        texts = {n["result"]: n.get("text", "") for n in qa.get("steps", []) if n.get("op") == "unique"}
        for i in _named_ids(qa):
            if i != qa.get("target_id"):
                _outline(ax, seg == i, color, grow, ls="--", lw=1.5)
            if (p := inside_point(seg == i)) is not None and texts.get(i):
                labels.append((*p, _short(texts[i]), color))
    return labels


def _short(text: str) -> str:
    return text if len(text) <= LABEL_CHARS else text[: LABEL_CHARS - 1].rstrip() + "\u2026"


def step_views(qa: dict) -> list[tuple[dict, str]]:
    """Each reasoning step with the view it was measured in. Steps do not say so themselves:
    the trace writes one Position step per ``unique`` node in program order, so the n-th
    Position step lies in the n-th unique node's view ("other" = image 1 of a multi-view QA).
    Extra Position steps (a free spot) are "self"; Size and Orientation steps carry no point."""
    views = [n.get("view") or "self" for n in qa.get("steps", []) if n.get("op") == "unique"]
    out, k = [], 0
    for step in qa.get("reasoning_steps") or []:
        view = "self"
        if step.get("kind") == "Position":
            view, k = (views[k] if k < len(views) else "self"), k + 1
        out.append((step, view))
    return out


def _located(qa: dict) -> list[dict]:
    """The reasoning steps with a point in this record's image."""
    return [s for s, view in step_views(qa) if view == "self" and "point" in s]


def free_region_mask(qa: dict, shape: tuple[int, int]) -> np.ndarray | None:
    """The free-space region of a placement QA (``free_mask``, the row-major run-length code of
    ``refspatial.annotate``) as a bool mask of the record's image, else None."""
    if not isinstance(qa.get("free_mask"), dict):
        return None
    from .annotate import rle_decode

    try:
        mask = rle_decode(qa["free_mask"])
    except (KeyError, TypeError, ValueError) as e:
        raise ShowError(f"QA {qa.get('qa_id')}: free_mask is not a valid run-length code ({e})") from None
    if mask.shape != tuple(shape):
        raise ShowError(f"QA {qa.get('qa_id')}: free_mask is {mask.shape[0]}x{mask.shape[1]} but the image is "
                        f"{shape[0]}x{shape[1]}; the mask must be the record's own view")
    return mask
