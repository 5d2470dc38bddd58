"""The audit report: one self-contained HTML page of plots and tables a person can look at.

Built from the dict ``refspatial.stats.collect`` returns (JSON topics only, so it is fast)
plus the manifest. Plots are matplotlib figures rendered with Agg and embedded as base64
PNG, so the file can be mailed or attached to an issue with nothing beside it. The bytes
depend on the data alone: no timestamps, no paths, PNGs written without a Software tag.
"""

from __future__ import annotations

import base64
import html
import io
from pathlib import Path
from typing import Callable

import numpy as np

from .stats import NO_WARNINGS, PREDICATE_SHARE_MAX, REGION_SHARE_MAX, answer_threshold, predicate_families

DPI = 100
STYLE = {"font.size": 9, "axes.titlesize": 10, "axes.spines.top": False, "axes.spines.right": False,
         "font.family": "DejaVu Sans", "svg.hashsalt": "refspatial"}
QA_COLOR, RELATION_COLOR, WARN_COLOR = "#1f6fb4", "#b0b7bf", "#c0392b"
MAX_STEPS = 5  # RefSpatial-Bench's range, shown in full so a missing step count is visible
VISIBILITY_STATUSES = ("visible", "marginal", "hidden")  # all shown, so a status that never occurs is seen


class ReportError(ValueError):
    """The report cannot be written where asked; the message says which path to pass instead."""


def write_report(stats: dict, manifest: dict, out: Path) -> Path:
    """Write the HTML report to ``out`` (parent folders are created) and return the path."""
    out = Path(out)
    if out.suffix.lower() not in (".html", ".htm"):
        raise ReportError(f"--report {out}: expected a file path ending in .html")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)  # fails fast, before the seconds of plotting
        out.write_text(render_html(stats, manifest), encoding="utf-8")
    except OSError as e:
        raise ReportError(f"--report {out}: cannot write it ({e.strerror}); choose another path") from None
    return out


def render_html(stats: dict, manifest: dict) -> str:
    """The whole page as a string (pure: same stats and manifest, same bytes)."""
    import matplotlib

    body = [_summary(stats, manifest), _balance(stats), _images(stats)]
    with matplotlib.rc_context(STYLE):
        for title, plot, tables in _SECTIONS:
            body.append(f"<h2>{title}</h2>\n{_img(plot(stats), title)}\n"
                        f"<div class=tables>{''.join(_table(stats, k, t) for k, t in tables)}</div>")
    return _PAGE.format(title=html.escape(f"refspatial audit: {stats['recipe']}"), body="\n".join(body))


# --- page pieces ----------------------------------------------------------------------------------


def _summary(stats: dict, manifest: dict) -> str:
    gen = manifest.get("generator", {})
    packages = ", ".join(f"{k} {v}" for k, v in sorted(gen.get("packages", {}).items()))
    digest = manifest.get("recipe_hash", "")
    rows = [("recipe", f"{stats['recipe']} (hash {digest if '+' in digest else digest[:12]})"),
            ("base seed", manifest.get("base_seed")),
            ("scenes / records / QA", f"{stats['scenes']} / {stats['records']} / {stats['qa']} "
                                      f"({stats['qa_per_record']} QA per record)"),
            ("rejected scenes", f"{stats['rejected']['count']} ({stats['rejected']['rate']:.1%})"),
            ("shards", stats["shards"]), ("image sizes", ", ".join(stats.get("image_sizes", {}))),
            ("generator", f"refspatial {gen.get('refspatial', '?')}, python {gen.get('python', '?')}; {packages}")]
    cells = "".join(f"<tr><th>{html.escape(str(k))}</th><td>{html.escape(str(v))}</td></tr>" for k, v in rows)
    return f"<table class=summary>{cells}</table>"


def _balance(stats: dict) -> str:
    warnings = stats.get("warnings", [])
    # A red "none" read as an alarm; the all-clear is a plain sentence in the page's "ok" colour.
    items = "".join(f"<li>{html.escape(w)}</li>" for w in warnings)
    listing = f"<ul class=warnings>{items}</ul>" if warnings else f"<p class=ok>{NO_WARNINGS}</p>"
    rows = "".join(
        f"<tr class={b['verdict'].replace(' ', '-')}><td>{html.escape(b['check'])}</td>"
        f"<td>{html.escape(str(b['item']))}</td><td>{b['count']} / {b['total']}</td>"
        f"<td>{b['share']:.1%}</td><td>{b['lower']:.1%} - {b['upper']:.1%}</td><td>{b['threshold']:.0%}</td>"
        f"<td>{html.escape(b['verdict'])}</td></tr>" for b in stats.get("balance", []))
    return ("<h2>Balance warnings</h2>\n"
            f"{listing}\n<table><tr><th>check</th><th>item</th><th>count</th>"
            "<th>share</th><th>95% interval</th><th>threshold</th><th>verdict</th></tr>"
            f"{rows}</table>\n<p class=note>A dominance check (the most common predicate, answer or image "
            "cell) warns when the interval's lower end is above its threshold; the step check (the step "
            "count furthest below the recipe's share for it) warns when the upper end is below half that "
            "share. Either is beyond sampling noise then; <i>watch</i> means past the threshold but within "
            "noise.</p>")


def _images(stats: dict) -> str:
    """The image audit (image_stats.py): void pixels, colour confusions, looks, lights, sources."""
    images = stats.get("images")
    if not images:
        return ""
    facts = [("pixels with no surface", f"{images['void_share']:.4%} ({images['records_with_void']} records with any)"),
             ("colour confusions", f"{images['colour_confusions']} of {images['colour_pairs']} pairs told apart by "
                                   f"colour ({images['colour_confusion_share']:.1%})")]
    cells = "".join(f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>" for k, v in facts)
    examples = "".join(f"<li>{html.escape(e)}</li>" for e in images["colour_confusion_examples"])
    kelvin = images["light_kelvin"]
    bins = {f"{lo}-{hi} K": n for lo, hi, n in zip(kelvin["edges"], kelvin["edges"][1:], kelvin["counts"]) if n}
    tables = "".join(_table({"t": counts}, "t", title) for counts, title in (
        (images["object_looks"], "object looks"), (images["surface_looks"], "room surfaces"),
        (images["lights_per_scene"], "lights per scene"), (bins, "light colour temperature"),
        (images["asset_sources"], "asset sources")))
    return (f"<h2>Images</h2>\n<table class=summary>{cells}</table>\n"
            + (f"<ul class=warnings>{examples}</ul>\n" if examples else "") + f"<div class=tables>{tables}</div>")


def _table(stats: dict, key: str, title: str) -> str:
    counts = stats
    for part in key.split("."):  # "rejected.reasons" reaches into nested dicts
        counts = counts.get(part, {})
    if not counts:
        return ""
    total = sum(counts.values()) or 1
    rows = "".join(f"<tr><td>{html.escape(str(k))}</td><td>{v}</td><td>{v / total:.1%}</td></tr>"
                   for k, v in counts.items())
    return f"<table><caption>{html.escape(title)}</caption>{rows}</table>"


def _img(fig, alt: str) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, metadata={"Software": None})
    data = base64.b64encode(buf.getvalue()).decode("ascii")
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'


def _figure(rows: int, cols: int, height_in: float, width_in: float = 10.0):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), dpi=DPI, layout="constrained")
    return fig, fig.subplots(rows, cols, squeeze=False).ravel()


# --- plots ------------------------------------------------------------------------------------------


def _barh(ax, counts: dict, title: str, color="C0") -> None:
    """Horizontal bars of shares, largest on top, each labelled with its count."""
    labels, values = list(counts)[::-1], np.array(list(counts.values())[::-1], dtype=float)
    shares = 100 * values / max(values.sum(), 1)
    ax.barh(labels, shares, color=color, edgecolor="#333", linewidth=0.4)
    for y, (s, v) in enumerate(zip(shares, values)):
        ax.text(s, y, f" {int(v)}", va="center", fontsize=7)
    ax.set_title(title)
    ax.set_xlabel("share (%)")
    ax.margins(x=0.15)


def _plot_predicates(stats: dict):
    families = predicate_families()
    names = sorted(set(stats["qa_predicates"]) | set(stats["relation_predicates"]),
                   key=lambda p: (families.get(p, "~"), p))
    fig, (ax, ax_f) = _figure(1, 2, 0.9 + 0.28 * max(len(names), 4))
    for panel, keys, qa, rel in ((ax, names, "qa_predicates", "relation_predicates"),
                                 (ax_f, list(stats["relation_predicate_families"]),
                                  "qa_predicate_families", "relation_predicate_families")):
        keys = list(dict.fromkeys([*keys, *stats[qa]]))[::-1]
        y = np.arange(len(keys))
        for offset, key, color, label in ((0.2, qa, QA_COLOR, "in QA"), (-0.2, rel, RELATION_COLOR, "true relations")):
            total = max(sum(stats[key].values()), 1)
            panel.barh(y + offset, [100 * stats[key].get(k, 0) / total for k in keys], 0.4, color=color, label=label)
        panel.set_yticks(y, keys)
        panel.set_xlabel("share (%)")
    ax.set_yticks(ax.get_yticks(), [f"{k} ({families.get(k, 'unregistered')})" for k in names[::-1]])
    ax.axvline(100 * PREDICATE_SHARE_MAX, color=WARN_COLOR, ls="--", lw=1, label="QA warning threshold")
    ax.set_title("predicates (family)")
    ax_f.set_title("predicate families")
    ax.legend(loc="lower right", fontsize=7)
    return fig


def _plot_questions(stats: dict):
    fig, axes = _figure(1, 4, max(2.6, 0.9 + 0.22 * max(len(stats["kinds"]), len(stats["families"]))), 12)
    _int_bars(axes[0], stats["steps"], "QA per step count", low=1, high=MAX_STEPS)
    _int_bars(axes[3], stats["question_words"], "question words (no point suffix)")
    _barh(axes[1], stats["families"], "QA per family")
    _barh(axes[2], stats["kinds"], "QA per kind")
    return fig


def _plot_objects(stats: dict):
    from matplotlib.colors import is_color_like

    n = max(len(stats["categories"]), len(stats["colors"]), 4)
    fig, axes = _figure(1, 3, 0.9 + 0.22 * n, 12)
    _barh(axes[0], stats["categories"], "objects per category")
    colors = [c if is_color_like(c) else "#999" for c in list(stats["colors"])[::-1]]
    _barh(axes[1], stats["colors"], "objects per colour word", color=colors)
    _int_bars(axes[2], stats["objects_per_record"], "records by object count")
    axes[2].set_xlabel("objects in the scene")
    return fig


def _int_bars(ax, counts: dict, title: str, low: int | None = None, high: int | None = None) -> None:
    """Bars over every integer from the smallest to the largest key, so gaps show as gaps."""
    from matplotlib.ticker import MaxNLocator

    keys = [int(k) for k in counts]
    lo, hi = min(keys + ([low] if low else []), default=0), max(keys + ([high] if high else []), default=0)
    xs = np.arange(lo, hi + 1)
    ax.bar(xs, [counts.get(str(x), 0) for x in xs], color=QA_COLOR)
    ax.set_title(title)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))


def _plot_visibility(stats: dict):
    from .relations.facts import VISIBLE_SHARE_OF_IMAGE

    edges, counts = stats["visible_share"]["edges_pct"], stats["visible_share"]["counts"]
    fig, (ax, ax_s) = _figure(1, 2, 2.8)
    ax.bar(range(len(counts)), counts, color=QA_COLOR)
    ax.set_xticks(range(len(counts)), [f"{a:g}-{b:g}" for a, b in zip(edges, edges[1:])], rotation=45, fontsize=7)
    ax.axvline(_bin_position(100 * VISIBLE_SHARE_OF_IMAGE, edges), color=WARN_COLOR, ls="--", lw=1,
               label="askable from here")
    ax.set_title("objects by visible pixels (% of the image)")
    ax.legend(fontsize=7)
    statuses = {k: stats["visibility_status"].get(k, 0) for k in VISIBILITY_STATUSES}
    _barh(ax_s, {**statuses, **stats["visibility_status"]}, "objects by visibility status")
    return fig


def _bin_position(value: float, edges: list[float]) -> float:
    """Where ``value`` falls on a categorical bar axis (bar i spans i-0.5..i+0.5), log-interpolated."""
    i = int(np.searchsorted(edges, value, side="right")) - 1
    lo, hi = max(edges[i], 1e-9), edges[i + 1]
    return i - 0.5 + float(np.log(max(value, lo) / lo) / np.log(hi / lo))


def _plot_heatmap(stats: dict):
    from matplotlib.patches import Rectangle
    from matplotlib.patheffects import withStroke

    pts = stats["answer_points"]
    grid = np.array(pts["grid"], dtype=float)
    w, h = (int(v) for v in (next(iter(stats.get("image_sizes", {})), "16x9")).split("x"))
    fig, (ax,) = _figure(1, 1, 4.2, 6.5)
    im = ax.imshow(grid, extent=(0, 1, 1, 0), cmap="magma", interpolation="nearest", aspect=h / w)
    fig.colorbar(im, ax=ax, shrink=0.8, label="answer points per bin")
    total = max(pts["count"], 1)
    for r in range(3):
        for c in range(3):
            share = pts["grid3"][r][c] / total
            ax.text((c + 0.5) / 3, (r + 0.5) / 3, f"{share:.0%}", ha="center", va="center", fontsize=11,
                    color="white", fontweight="bold", path_effects=[withStroke(linewidth=2.5, foreground="black")])
            if share > REGION_SHARE_MAX:
                ax.add_patch(Rectangle((c / 3, r / 3), 1 / 3, 1 / 3, fill=False, ec=WARN_COLOR, lw=2.5))
    for t in (1 / 3, 2 / 3):
        ax.axhline(t, color="white", lw=0.6, ls=":")
        ax.axvline(t, color="white", lw=0.6, ls=":")
    ax.set_title(f"answer points over the normalised image ({pts['count']} points; red box: over "
                 f"{REGION_SHARE_MAX:.0%})")
    ax.set_xlabel("x (0 = left)")
    ax.set_ylabel("y (0 = top)")
    return fig


def _plot_answers(stats: dict):
    kinds = stats["answers_by_kind"] or {"(no choice QA)": {}}
    fig, (ax,) = _figure(1, 1, 0.8 + 0.45 * len(kinds), 8)
    for y, (kind, counts) in enumerate(kinds.items()):
        total, left = max(sum(counts.values()), 1), 0.0
        for j, (answer, n) in enumerate(sorted(counts.items())):
            share = 100 * n / total
            ax.barh(y, share, left=left, color=f"C{j}", edgecolor="white")
            ax.text(left + share / 2, y, f"{answer} {share:.0f}% ({n})", ha="center", va="center", fontsize=8)
            left += share
        if counts:
            x = 100 * answer_threshold(stats, kind)
            ax.plot([x, x], [y - 0.45, y + 0.45], color=WARN_COLOR, ls="--", lw=1.2)
    ax.set_yticks(range(len(kinds)), list(kinds))
    ax.set_xlim(0, 100)
    ax.set_xlabel("share of the kind's answers (%)")
    ax.set_title("letter answers per kind (dashed: share one answer may reach)")
    return fig


def _plot_rejections(stats: dict):
    groups = stats["rejected_by_recipe"]
    fig, axes = _figure(1, len(groups), max(1.4, 1.0 + 0.3 * max(len(g["reasons"]) for g in groups.values())), 8)
    for ax, (recipe, g) in zip(axes, groups.items()):
        if g["reasons"]:
            _barh(ax, dict(sorted(g["reasons"].items(), key=lambda kv: -kv[1])), "", color=WARN_COLOR)
        else:
            ax.text(0.5, 0.5, "no scene rejected", ha="center", va="center", transform=ax.transAxes)
            ax.set_axis_off()
        ax.set_title(f"{recipe}: {g['count']} of {g['scenes']} scenes rejected ({g['rate']:.1%})")
    return fig


_SECTIONS: list[tuple[str, Callable, list[tuple[str, str]]]] = [
    ("Predicates", _plot_predicates, [("qa_predicates", "QA predicates"),
                                      ("relation_predicates", "true relations"),
                                      ("qa_predicate_families", "QA predicate families")]),
    ("Questions", _plot_questions, [("families", "families"), ("kinds", "kinds"), ("steps", "step counts")]),
    ("Choice-answer balance", _plot_answers, [("answers", "choice answers")]),
    ("Answer points", _plot_heatmap, []),
    ("Objects", _plot_objects, [("categories", "categories"), ("colors", "colours"),
                                ("objects_per_record", "objects per record")]),
    ("Visibility", _plot_visibility, [("visibility_status", "visibility status")]),
    ("Rejected scenes", _plot_rejections, [("rejected.reasons", "rejection reasons")]),
]

_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<style>
body {{ font-family: sans-serif; max-width: 1250px; margin: 1em auto; color: #222; }}
img {{ max-width: 100%; display: block; margin: 0.5em 0; }}
table {{ border-collapse: collapse; font-size: 12px; margin: 0 1em 1em 0; vertical-align: top; }}
td, th {{ border: 1px solid #ccc; padding: 2px 6px; text-align: left; }}
caption {{ font-weight: bold; text-align: left; }}
.tables {{ display: flex; flex-wrap: wrap; align-items: flex-start; }}
.warnings li {{ color: #c0392b; }} .ok {{ color: #1e7b34; }} tr.warn td {{ background: #f8d7d3; }} tr.watch td {{ background: #fcf0cf; }}
.note {{ font-size: 12px; color: #555; }}
</style></head>
<body><h1>{title}</h1>
{body}
</body></html>
"""
