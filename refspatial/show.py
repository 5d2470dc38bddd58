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
from pathlib import Path

import numpy as np

from .atomic import file_in_the_way, replacing
from .show_layout import (BACKGROUND_RGB, CHAR_PX, DEFAULT_QA, DPI, LABEL_PX, LINE_PX, PAD_PX, PANEL_WIDTH_PX,
                          QA_COLORS, TEXT_PX, TITLE_PX, Layout, ShowError, axes, pt)
from .show_overlay import annotate, inside_point, step_views, with_marks, zoom_box


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
    lay = Layout(w, h, zoom_box(sample["seg"], qas) if zoom else (0.0, 0.0, w, h), len(lines))
    fw, fh = lay.size
    fig = Figure(figsize=(fw / DPI, fh / DPI), dpi=DPI, facecolor="white")
    scene = sample["scene"]
    title = (f"{sample['key']}   ({sample['shard']} #{sample['index']}, {scene['width']}x{scene['height']}, "
             f"recipe {scene['recipe']})")
    fig.text(PAD_PX / fw, 1 - (TITLE_PX / 2) / fh, title, fontsize=pt(TEXT_PX), va="center", fontweight="bold")
    main = axes(fig, lay, lay.main)
    main.imshow(with_marks(sample["rgb"], qas), extent=(0, w, h, 0), interpolation="nearest")
    annotate(main, sample["seg"], qas, lay)
    _draw_depth(axes(fig, lay, lay.side(0)), sample["depth_m"], sample["seg"])
    _draw_seg(axes(fig, lay, lay.side(1)), sample["seg"])
    for i, (line, bullet) in enumerate(lines):
        y = 1 - (lay.main[1] + lay.main[3] + PAD_PX + (i + 0.5) * LINE_PX) / fh
        if bullet:
            fig.text(PAD_PX / fw, y, "\u25cf", color=bullet, fontsize=pt(TEXT_PX + 2), va="center")
        fig.text((PAD_PX + 24) / fw, y, line, fontsize=pt(TEXT_PX), va="center", fontweight="bold" if bullet else None)
    if (blocker := file_in_the_way(Path(out).parent)) is not None:
        raise ShowError(f"--out {out}: {blocker} is a file, not a folder; choose another path")
    try:
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        with replacing(Path(out)) as tmp:
            fig.savefig(tmp, format="png", dpi=DPI, metadata={"Software": None}, pil_kwargs={"compress_level": 9})
    except OSError as e:
        raise ShowError(f"--out {out}: cannot write it ({e.strerror or e}); choose another path") from None
    return lay


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

    ax.text(x, y, text, transform=transform or ax.transAxes, color="white", fontsize=pt(LABEL_PX),
            path_effects=[withStroke(linewidth=2.5, foreground="black")], clip_on=True, **{"va": "top", **kw})


def _draw_seg(ax, seg: np.ndarray) -> None:
    from matplotlib import colormaps

    palette = (np.array(colormaps["tab20"].colors) * 255).astype(np.uint8)
    rgb = np.where(seg[..., None] >= 0, palette[np.maximum(seg, 0) % len(palette)], np.uint8(BACKGROUND_RGB))
    ax.imshow(rgb, extent=(0, seg.shape[1], seg.shape[0], 0), interpolation="nearest")
    for oid in np.unique(seg[seg >= 0]):
        x, y = inside_point(seg == oid)
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
        steps = "  ".join(_step_text(s) + (" in image 1" if v != "self" else "") for s, v in step_views(qa))
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
