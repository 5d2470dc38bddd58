"""``refspatial show``: one record drawn so a person can check its answers by eye.

The RGB panel carries each chosen QA in its own colour: the target's mask outlined, answer
points as filled markers, reasoning-step points numbered in order with their text, objects
a question without a trace names outlined dashed, visual-choice boxes, and the free-space
region of a placement QA. Beside it: depth (turbo, near and far in metres) and segmentation
(one colour per object id, ids inside each mask); under it the questions and answers. The
RGB panel is always ``PANEL_WIDTH_PX`` wide: a 960x540 render is drawn 1:1, a 192x108 one
scaled up 5x (nearest); ``zoom`` crops all panels to what the QAs touch.
"""

from __future__ import annotations

import argparse
import textwrap
from dataclasses import dataclass
from pathlib import Path

import numpy as np

PANEL_WIDTH_PX = 960
DPI = 128  # a power of two: figure inches * DPI is an exact pixel count, so the layout is exact
GAP_PX, TITLE_PX, PAD_PX = 6, 30, 10
TEXT_PX, LABEL_PX = 15, 13  # font heights (pixels) of the text block and of labels on the images
LINE_PX = round(TEXT_PX * 1.4)
CHAR_PX = TEXT_PX * 0.6  # DejaVu Sans averages under 0.6 em per character, so wrapped lines fit
MARKER_PX, STEP_PX = 16, 18  # diameters of answer markers and numbered step discs
RING_PX = 5  # the k-th QA's outlines lie k * RING_PX outside the mask, so shared objects show every ring
LABEL_CHARS = 28  # step texts are cut to this on the image; the text block keeps them whole
DEFAULT_QA = 4  # QAs drawn when --qa is not given; more crowd the picture
QA_COLORS = ("#ff1493", "#00b4ff", "#ffa500", "#32cd32", "#a45cff", "#ff4500")
BACKGROUND_RGB = (40, 40, 40)  # segmentation background, and depth pixels where nothing was hit


class ShowError(ValueError):
    """A record or QA index that does not exist, or a bad --out; the message says what to pass."""


@dataclass(frozen=True)
class Layout:
    """Where everything lands in the output PNG, in output pixels (origin top-left)."""

    width: int  # the record's image size
    height: int
    crop: tuple[float, float, float, float]  # x0, y0, w, h of the record shown, record pixels
    text_lines: int

    @property
    def scale(self) -> float:  # output pixels per record pixel in the RGB panel
        return PANEL_WIDTH_PX / self.crop[2]

    @property
    def main(self) -> tuple[int, int, int, int]:  # x, y, w, h
        return 0, TITLE_PX, PANEL_WIDTH_PX, round(self.crop[3] * self.scale)

    def side(self, k: int) -> tuple[int, int, int, int]:
        """Depth (k=0) and segmentation (k=1), stacked right of the RGB panel at half size."""
        _, y, w, h = self.main
        return w + GAP_PX, y + k * (h // 2 + GAP_PX // 2), w // 2, h // 2 - GAP_PX // 2

    @property
    def size(self) -> tuple[int, int]:  # output width, height
        _, y, w, h = self.main
        return w + GAP_PX + w // 2, y + h + 2 * PAD_PX + self.text_lines * LINE_PX

    def panel_xy(self, x: float, y: float) -> tuple[float, float]:
        """Record pixel coordinates -> output pixels within the RGB panel."""
        return (x - self.crop[0]) * self.scale, (y - self.crop[1]) * self.scale

    def to_pixel(self, x: float, y: float) -> tuple[int, int]:
        """Output (column, row) of a normalised record point."""
        px, py = self.panel_xy(x * self.width, y * self.height)
        return int(self.main[0] + px), int(self.main[1] + py)


# --- command ---------------------------------------------------------------------------------------


def add_cli(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("show", help="draw one record with its QA, depth and segmentation as a PNG")
    p.add_argument("dir", type=Path, help="dataset folder (holds manifest.json)")
    p.add_argument("--record", type=int, required=True,
                   help="global record index: records numbered from 0 across shards in manifest order")
    p.add_argument("--out", type=Path, required=True, help="output .png path")
    p.add_argument("--qa", type=int, nargs="+", metavar="J",
                   help=f"QA indices within the record to draw (default: the first {DEFAULT_QA})")
    p.add_argument("--zoom", action="store_true", help="crop every panel to the objects and points the QAs touch")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.out.suffix.lower() != ".png":
        raise ShowError(f"--out {args.out}: expected a path ending in .png")
    sample = read_record(args.dir, args.record)
    chosen = choose_qa(sample, args.qa)
    render_record(sample, chosen, args.out, zoom=args.zoom)
    print(f"wrote {args.out} (record {args.record} = {sample['key']}, QA {', '.join(map(str, chosen))} "
          f"of {len(sample['qa'])})")
    return 0


def read_record(root: Path, index: int) -> dict:
    """Record ``index`` counted across shards in manifest order, with rgb, depth and seg."""
    from .manifest import read_manifest
    from .records import ShardReader

    shards = read_manifest(root)["shards"]
    total = sum(s["records"] for s in shards)
    if total == 0:
        raise ShowError(f"--record {index}: {root} holds no records; generate some with `refspatial generate`")
    if not 0 <= index < total:
        raise ShowError(f"--record {index} is out of range; {root} holds records 0..{total - 1}, numbered "
                        "across shards in manifest order")
    for s in shards:
        if index < s["records"]:
            return ShardReader(Path(root) / s["file"]).read(index)
        index -= s["records"]
    raise AssertionError("unreachable: index checked against the total")


def choose_qa(sample: dict, wanted: list[int] | None) -> list[int]:
    n = len(sample["qa"])
    if wanted is None:
        return list(range(min(n, DEFAULT_QA)))
    bad = [j for j in wanted if not 0 <= j < n]
    if bad:
        raise ShowError(f"--qa {bad[0]}: record {sample['key']} has QA {f'0..{n - 1}' if n else 'none'}")
    return list(dict.fromkeys(wanted))


# --- drawing ---------------------------------------------------------------------------------------


def render_record(sample: dict, qa_indices: list[int], out: Path, zoom: bool = False) -> Layout:
    """Draw ``sample`` (a ShardReader.read dict with rgb, depth_m, seg) with the chosen QAs."""
    from matplotlib.figure import Figure

    h, w = sample["seg"].shape
    qas = [(j, sample["qa"][j], QA_COLORS[k % len(QA_COLORS)]) for k, j in enumerate(qa_indices)]
    lines = _text_lines(qas)
    lay = Layout(w, h, _zoom_box(sample["seg"], qas) if zoom else (0.0, 0.0, w, h), len(lines))
    fw, fh = lay.size
    fig = Figure(figsize=(fw / DPI, fh / DPI), dpi=DPI, facecolor="white")
    scene = sample["scene"]
    title = (f"{sample['key']}   ({sample['shard']} #{sample['index']}, {scene['width']}x{scene['height']}, "
             f"recipe {scene['recipe']})")
    fig.text(PAD_PX / fw, 1 - (TITLE_PX / 2) / fh, title, fontsize=_pt(TEXT_PX), va="center", fontweight="bold")
    main = _axes(fig, lay, lay.main)
    main.imshow(_with_marks(sample["rgb"], qas), extent=(0, w, h, 0), interpolation="nearest")
    _annotate(main, sample["seg"], qas, lay)
    _draw_depth(_axes(fig, lay, lay.side(0)), sample["depth_m"], sample["seg"])
    _draw_seg(_axes(fig, lay, lay.side(1)), sample["seg"])
    for i, (line, bullet) in enumerate(lines):
        y = 1 - (lay.main[1] + lay.main[3] + PAD_PX + (i + 0.5) * LINE_PX) / fh
        if bullet:
            fig.text(PAD_PX / fw, y, "\u25cf", color=bullet, fontsize=_pt(TEXT_PX + 2), va="center")
        fig.text((PAD_PX + 24) / fw, y, line, fontsize=_pt(TEXT_PX), va="center", fontweight="bold" if bullet else None)
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=DPI, metadata={"Software": None}, pil_kwargs={"compress_level": 9})
    return lay


def _zoom_box(seg: np.ndarray, qas: list) -> tuple[float, float, float, float]:
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


def _with_marks(rgb: np.ndarray, qas: list) -> np.ndarray:
    """The boxes visual-choice questions ask about, drawn as the model is shown them."""
    marks = [m for _, qa, _ in qas for m in qa.get("marks") or []]
    if not marks:
        return rgb
    from .annotate import draw_marks

    return draw_marks(rgb, marks)


def _pt(px: float) -> float:
    return px * 72 / DPI


def _axes(fig, lay: Layout, box: tuple[int, int, int, int]):
    fw, fh = lay.size
    x, y, bw, bh = box
    ax = fig.add_axes((x / fw, 1 - (y + bh) / fh, bw / fw, bh / fh))
    ax.set_axis_off()
    x0, y0, cw, ch = lay.crop
    ax.set_xlim(x0, x0 + cw)
    ax.set_ylim(y0 + ch, y0)
    return ax


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


def _inside_point(mask: np.ndarray) -> tuple[float, float] | None:
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


def _annotate(ax, seg: np.ndarray, qas: list, lay: Layout) -> None:
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
            ax.plot(x * w, y * h, "o", ms=_pt(MARKER_PX), mfc=color, mec="white", mew=1.5, zorder=6)
            block(x * w, y * h, MARKER_PX)
    for x, y, text, color in labels:
        cx, cy = _place(boxes, *lay.panel_xy(x, y), text, *lay.main[2:])
        xy = (lay.crop[0] + cx / lay.scale, lay.crop[1] + cy / lay.scale)
        ax.annotate(text, (x, y), xy, fontsize=_pt(LABEL_PX), ha="center", va="center", zorder=4,
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
        ax.plot(x, y, "o", ms=_pt(STEP_PX), mfc="white", mec=color, mew=2, zorder=5)
        ax.text(x, y, str(i), fontsize=_pt(LABEL_PX - 2), ha="center", va="center", fontweight="bold", zorder=5)
        block(x, y, STEP_PX)
        labels.append((x, y, _short(step["text"]), color))
    if not located:  # no trace in this view: name the objects the program picked
        texts = {n["result"]: n.get("text", "") for n in qa.get("steps", []) if n.get("op") == "unique"}
        for i in _named_ids(qa):
            if i != qa.get("target_id"):
                _outline(ax, seg == i, color, grow, ls="--", lw=1.5)
            if (p := _inside_point(seg == i)) is not None and texts.get(i):
                labels.append((*p, _short(texts[i]), color))
    return labels


def _short(text: str) -> str:
    return text if len(text) <= LABEL_CHARS else text[: LABEL_CHARS - 1].rstrip() + "\u2026"


def _step_views(qa: dict) -> list[tuple[dict, str]]:
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
    return [s for s, view in _step_views(qa) if view == "self" and "point" in s]


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


def _draw_depth(ax, depth: np.ndarray, seg: np.ndarray) -> None:
    """Turbo over the objects' depth range, widened 5 % and clipped beyond (questions are about
    objects; the room behind would squash them into one colour). Grey: nothing was hit."""
    from matplotlib import colormaps

    finite = np.isfinite(depth)
    top = finite & (depth >= 0.999 * depth[finite].max()) if finite.any() else finite
    rest = depth[finite & ~top]
    # MuJoCo returns the far clip distance where a ray hits nothing: a plateau far beyond the rest.
    empty = ~finite | (top if rest.size and depth[top].min() > 2 * rest.max() else False)
    values = depth[(seg >= 0) & ~empty] if ((seg >= 0) & ~empty).any() else depth[~empty]
    lo, hi = (float(values.min()), float(values.max())) if values.size else (0.0, 1.0)
    near, far = max(lo - 0.05 * (hi - lo), 0.0), hi + 0.05 * (hi - lo) + 1e-3
    rgb = colormaps["turbo"](np.clip((np.where(finite, depth, far) - near) / (far - near), 0, 1))[..., :3]
    rgb[empty] = np.array(BACKGROUND_RGB) / 255
    ax.imshow(rgb, extent=(0, depth.shape[1], depth.shape[0], 0), interpolation="antialiased")
    bar = ax.inset_axes((0.03, 0.04, 0.94, 0.05))
    bar.imshow(np.linspace(0, 1, 256)[None], cmap="turbo", aspect="auto")
    bar.set_axis_off()
    for x, ha, text in ((0.03, "left", f"near {near:.2f} m"), (0.97, "right", f"far {far:.2f} m")):
        _panel_text(ax, x, 0.11, text, ha=ha, va="bottom")
    note = "; grey: no surface" if empty.any() else ""
    _panel_text(ax, 0.03, 0.96, f"depth, objects' range (clipped beyond){note}")


def _panel_text(ax, x: float, y: float, text: str, transform=None, **kw) -> None:
    """White text with a black edge: legible on any colour."""
    from matplotlib.patheffects import withStroke

    ax.text(x, y, text, transform=transform or ax.transAxes, color="white", fontsize=_pt(LABEL_PX),
            path_effects=[withStroke(linewidth=2.5, foreground="black")], clip_on=True, **{"va": "top", **kw})


def _draw_seg(ax, seg: np.ndarray) -> None:
    from matplotlib import colormaps

    palette = (np.array(colormaps["tab20"].colors) * 255).astype(np.uint8)
    rgb = np.where(seg[..., None] >= 0, palette[np.maximum(seg, 0) % len(palette)], np.uint8(BACKGROUND_RGB))
    ax.imshow(rgb, extent=(0, seg.shape[1], seg.shape[0], 0), interpolation="nearest")
    for oid in np.unique(seg[seg >= 0]):
        x, y = _inside_point(seg == oid)
        _panel_text(ax, x, y, str(oid), transform=ax.transData, ha="center", va="center", fontweight="bold")
    _panel_text(ax, 0.03, 0.96, "segmentation (object ids)")


def _text_lines(qas: list) -> list[tuple[str, str | None]]:
    """Wrapped lines (text, bullet colour or None) under the images."""
    chars = int((PANEL_WIDTH_PX * 1.5 - 2 * PAD_PX - 24) / CHAR_PX)
    out: list[tuple[str, str | None]] = []
    for j, qa, color in qas:
        preds = ", ".join(qa.get("predicates", [])) or "no relation"
        head = f"Q{j} [{qa['family']}/{qa['kind']}, {qa['num_steps']} step(s), {preds}] {qa['prompt']}"
        suffix = " (+ point suffix)" if qa["question"] != qa["prompt"] else ""
        steps = "  ".join(_step_text(s) + (" in image 1" if v != "self" else "") for s, v in _step_views(qa))
        body = [f"answer: {_answer_text(qa)}"] + ([f"steps: {steps}"] if steps else [])
        for k, para in enumerate([head + suffix, *body]):
            for n, line in enumerate(textwrap.wrap(para, chars, subsequent_indent="    ")):
                out.append((line, color if k == 0 and n == 0 else None))
    return out


def _step_text(step: dict) -> str:
    """One reasoning step as in the trace: where (Position), which way (Orientation), how big (Size)."""
    value = step.get("point", step.get("vector", step.get("value", "")))
    return f"[{step.get('kind', '?')}] {step.get('text', '')}: {tuple(value) if isinstance(value, list) else value}"


def _answer_text(qa: dict) -> str:
    """The stored answer, plus what a choice letter stands for: "(A) yes", "(B) = the red cup"."""
    from .stats import answer_label

    if qa["kind"] == "point":
        return qa["answer"]
    names = [n["text"] for n in qa.get("steps", []) if n.get("op") == "unique" and n["result"] == qa.get("target_id")]
    return answer_label(qa) + (f" = {names[-1]}" if names else "")
