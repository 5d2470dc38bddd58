"""Dataset statistics for audits: what was generated, how it is spread, and what dominates.

Counts come from the JSON topics of each record; the image section (``image_stats``) decodes
the pixels to re-derive what they show. The answer-point heatmap uses the stored normalised
``answer_points``.
Every aggregate is a plain JSON value, so ``refspatial stats --json`` and the HTML report
(``refspatial.report``) read the same dict.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from pathlib import Path

import numpy as np
import yaml

from .image_stats import ImageTally
from .image_stats import format_text as format_images
from .manifest import read_manifest
from .records import ShardReader, sha256_file
from .shard_job import read_sidecar

# Answer-point histogram bins per axis. A multiple of 3, so the 3x3 balance grid is an exact
# sum of bins; 24 still shows where on an object-sized scale points pile up.
HEATMAP_BINS = 24
# Bin edges (percent of the image) of each object's visible pixel share. Log-like steps,
# because shares range from a few pixels (0.01 %) to a plate filling a fifth of the view.
VISIBLE_SHARE_EDGES_PCT = (0.0, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0)

# --- balance thresholds ---------------------------------------------------------------------------
# One predicate above 40 % of the predicates asked about: 12x a fair share among RefSpatial's
# 31 and still 2.4x among six, so a model could lean on the prior instead of reading the image.
PREDICATE_SHARE_MAX = 0.40
# One answer letter of a multiple-choice kind more than 10 points above its fair share (60 % of
# a yes/no or (A)/(B) kind, 35 % of a four-box visual choice, about 41 % where three and four
# boxes mix as the recipes draw them): always answering it would beat chance by that much with
# no spatial reasoning. CLEVR rejection-samples for the same reason.
ANSWER_MARGIN = 0.10
ANSWER_SHARE_MAX = 0.5 + ANSWER_MARGIN  # the two-option case, the common one
# One cell of a 3x3 grid over the image holding over 35 % of answer points (a fair share is
# 11 %): tabletop framing centres the objects, so the middle cell is allowed 3x its share,
# but beyond that "point at the centre" becomes a winning strategy on pointing benchmarks.
REGION_SHARE_MAX = 0.35
# A step count of the described questions below half the share the recipe asks for: the data no
# longer follows the recipe, and a model sees too few long chains to learn them. Half, not all,
# because small scenes cannot hold every chain (three objects leave no five-step description).
STEP_SHARE_MIN_RATIO = 0.5
# Every predicate in at least this share of the QA: 1 % of a dataset mixing several scene families,
# 0.5 % of a single recipe's (some predicates are rare in one family: inside on a bare shelf).
PREDICATE_FLOOR_MIXED = 0.01
PREDICATE_FLOOR_SINGLE = 0.005
# The all-clear, printed last so a run that ends quietly reads as checked, not as cut short.
NO_WARNINGS = "no balance warning fired"
# A check fires only beyond sampling noise: the 95 % Wilson interval of the share must lie
# wholly past the threshold (its lower end above a dominance threshold, its upper end below a
# shortfall one). A 12-scene smoke run holds ~40 choice answers, where 63 % for one letter is
# still within chance of a fair coin.
CONFIDENCE_Z = 1.96

_COUNTERS = ("qa_predicates", "relation_predicates", "qa_predicate_families", "relation_predicate_families",
             "steps", "families", "kinds", "categories", "colors", "objects_per_record", "answers",
             "visibility_status", "question_words", "image_sizes")


def load_manifest(root: Path) -> dict:
    """``root``'s manifest; a missing or damaged one is a one-line error saying how to rebuild it."""
    return read_manifest(root)


class _Tally:
    """Running counts over records; one instance per ``collect`` call."""

    def __init__(self) -> None:
        self.c: dict[str, Counter] = {name: Counter() for name in _COUNTERS}
        self.answers_by_kind: dict[str, Counter] = {}
        self.steps_by_family: dict[str, Counter] = {}
        self.option_counts: dict[str, Counter] = {}  # kind -> {number of options: questions}
        self.points = np.zeros((HEATMAP_BINS, HEATMAP_BINS), dtype=np.int64)  # rows = y, cols = x
        self.visible_share = np.zeros(len(VISIBLE_SHARE_EDGES_PCT) - 1, dtype=np.int64)
        self.families = predicate_families()

    def add_record(self, sample: dict) -> None:
        scene = sample["scene"]
        objects = scene["objects"]
        self.c["image_sizes"][f"{scene['width']}x{scene['height']}"] += 1
        self.c["objects_per_record"][len(objects)] += 1
        self.c["categories"].update(o["category"] for o in objects)
        self.c["colors"].update(o["color"] for o in objects)
        self.c["visibility_status"].update(o["visibility"] for o in objects)
        pixels = scene["width"] * scene["height"]
        shares = [100.0 * o["visible_px"] / pixels for o in objects]
        self.visible_share += np.histogram(shares, bins=VISIBLE_SHARE_EDGES_PCT)[0]
        for r in sample["relations"]:
            self._predicate("relation", r["predicate"])
        for qa in sample["qa"]:
            self.add_qa(qa)

    def add_qa(self, qa: dict) -> None:
        self.c["families"][qa["family"]] += 1
        self.c["kinds"][qa["kind"]] += 1
        self.c["steps"][qa["num_steps"]] += 1
        self.steps_by_family.setdefault(qa["family"], Counter())[qa["num_steps"]] += 1
        self.c["question_words"][len(qa["prompt"].split())] += 1
        for p in qa["predicates"]:
            self._predicate("qa", p)
        options = len(set(re.findall(r"\(([A-Z])\)", qa["question"])))
        if options >= 2 and re.fullmatch(r"\([A-Z]\)", qa["answer"]):  # letters, not values ("13 cm")
            self.c["answers"][qa["answer"]] += 1
            self.answers_by_kind.setdefault(qa["kind"], Counter())[answer_label(qa)] += 1
            self.option_counts.setdefault(qa["kind"], Counter())[options] += 1
        for x, y in qa["answer_points"]:
            col = min(max(int(x * HEATMAP_BINS), 0), HEATMAP_BINS - 1)
            row = min(max(int(y * HEATMAP_BINS), 0), HEATMAP_BINS - 1)
            self.points[row, col] += 1

    def _predicate(self, where: str, name: str) -> None:
        self.c[f"{where}_predicates"][name] += 1
        self.c[f"{where}_predicate_families"][self.families.get(name, "unregistered")] += 1


def predicate_families() -> dict[str, str]:
    """Predicate -> family from the registry, so a newly registered predicate is grouped at once."""
    from .relations import PREDICATES

    return {name: p.family for name, p in PREDICATES.items()}


def answer_label(qa: dict) -> str:
    """The answer letter plus its option when that is one word: "(A) yes", "(B) right";
    longer options ("(A) the blue vase") differ per question and are left out."""
    m = re.search(re.escape(qa["answer"]) + r" (\w+)(?= \([A-Z]\)|[?.]?$)", qa["question"])
    return f"{qa['answer']} {m.group(1)}" if m else qa["answer"]


def collect(*roots: Path) -> dict:
    """Statistics over one dataset folder, or over several (one per scene family) as one."""
    manifests = [load_manifest(root) for root in roots]
    tally, images, integrity = _Tally(), ImageTally(), []
    for root, manifest in zip(roots, manifests):
        for shard in manifest["shards"]:
            integrity += checksum_problems(Path(root), shard)
            for sample in ShardReader(Path(root) / shard["file"]).iter():
                tally.add_record(sample)
                images.add(sample)
    manifest = merge_manifests(manifests)
    by_recipe: dict[str, dict] = {}
    for m in manifests:
        for recipe, row in rejections_by_recipe(m).items():
            if recipe in by_recipe:  # two folders of one recipe: add them up
                old = by_recipe[recipe]
                row = {"scenes": old["scenes"] + row["scenes"], "count": old["count"] + row["count"],
                       "reasons": dict(Counter(old["reasons"]) + Counter(row["reasons"]))}
                row["rate"] = round(row["count"] / row["scenes"], 4) if row["scenes"] else 0.0
            by_recipe[recipe] = row
    stats = {
        "recipe": manifest["recipe"],
        "scenes": manifest["scenes"],
        "records": manifest["records"],
        "qa": manifest["qa"],
        "shards": len(manifest["shards"]),
        "rejected": {k: manifest["rejected"][k] for k in ("count", "rate", "reasons")},
        "rejected_by_recipe": by_recipe,
        "qa_per_record": round(manifest["qa"] / manifest["records"], 2) if manifest["records"] else 0.0,
        **{name: _sorted(counter) for name, counter in tally.c.items()},
        "answers_by_kind": {k: _sorted(v) for k, v in sorted(tally.answers_by_kind.items())},
        "steps_by_family": {k: _by_number(_sorted(v)) for k, v in sorted(tally.steps_by_family.items())},
        "steps_wanted": wanted_steps(manifests),
        "answer_options": {k: max(v) for k, v in sorted(tally.option_counts.items())},  # the most one offers
        "answer_option_counts": {k: _by_number(_sorted(v)) for k, v in sorted(tally.option_counts.items())},
        "visible_share": {"edges_pct": list(VISIBLE_SHARE_EDGES_PCT), "counts": tally.visible_share.tolist()},
        "answer_points": _points_summary(tally.points),
        "images": images.summary(),
    }
    stats["question_words"] = _by_number(stats["question_words"])
    stats["balance"] = balance_checks(stats)
    stats["warnings"] = [b["message"] for b in stats["balance"] if b["verdict"] == "warn"]
    stats["integrity"] = integrity
    return stats


def checksum_problems(root: Path, shard: dict) -> list[str]:
    """A shard whose bytes differ from what its sidecar and the manifest recorded was changed
    after it was written: its counts can no longer be trusted. Empty when both agree."""
    path = root / shard["file"]
    if not path.is_file():
        return []  # the reader says so, in one line
    actual, out = sha256_file(path), []
    sidecar = read_sidecar(path.with_suffix(".json")) or {}
    for what, recorded in (("its sidecar", sidecar.get("sha256")), ("manifest.json", shard.get("sha256"))):
        if recorded is not None and recorded != actual:
            out.append(f"{path}: sha256 {actual[:12]}... differs from {what}'s {str(recorded)[:12]}...; the file "
                       "changed after it was written: run `refspatial verify` on it, and re-run the generate "
                       "command to redo it")
    return out[:1]  # one line per shard: a changed file usually differs from both


def merge_manifests(manifests: list[dict]) -> dict:
    """One manifest-shaped summary of several datasets: counts added, recipes joined with '+'."""
    if len(manifests) == 1:
        return manifests[0]
    scenes = sum(m["scenes"] for m in manifests)
    rejected = sum(m["rejected"]["count"] for m in manifests)
    reasons = sum((Counter(m["rejected"]["reasons"]) for m in manifests), Counter())
    return {
        **manifests[0],
        "recipe": " + ".join(m["recipe"] for m in manifests),
        "recipe_hash": " + ".join(m.get("recipe_hash", "")[:12] for m in manifests),
        "base_seed": ", ".join(str(m.get("base_seed")) for m in manifests),
        "scenes": scenes, "records": sum(m["records"] for m in manifests), "qa": sum(m["qa"] for m in manifests),
        "shards": [s for m in manifests for s in m["shards"]],
        "rejected": {"count": rejected, "rate": round(rejected / scenes, 4) if scenes else 0.0,
                     "reasons": dict(sorted(reasons.items()))},
    }


def wanted_steps(manifests: list[dict]) -> dict[str, float] | None:
    """The recipe's step mix, normalised, keyed like the step counters; None when the folders'
    recipes ask for different mixes, or a manifest predates the resolved recipe."""
    mixes = []
    for m in manifests:
        steps = (yaml.safe_load(m.get("recipe_resolved_yaml") or "{}").get("questions") or {}).get("steps")
        if not steps:
            return None
        total = sum(steps.values())
        mixes.append({str(k): round(v / total, 4) for k, v in sorted(steps.items())})
    return mixes[0] if all(mix == mixes[0] for mix in mixes) else None


def rejections_by_recipe(manifest: dict) -> dict[str, dict]:
    """Rejected scenes per recipe. A manifest holds one recipe, so this is one entry keyed by
    it; the shape lets a report lay several datasets' rows side by side."""
    r = manifest["rejected"]
    return {manifest["recipe"]: {"scenes": manifest["scenes"], "count": r["count"], "rate": r["rate"],
                                 "reasons": dict(r["reasons"])}}


def _points_summary(grid: np.ndarray) -> dict:
    k = HEATMAP_BINS // 3
    grid3 = grid.reshape(3, k, 3, k).sum(axis=(1, 3))
    return {"bins": HEATMAP_BINS, "count": int(grid.sum()), "grid": grid.tolist(), "grid3": grid3.tolist()}


def _sorted(counter: Counter) -> dict:
    return {str(k): v for k, v in sorted(counter.items(), key=lambda kv: (-kv[1], str(kv[0])))}


def _by_number(counts: dict) -> dict:
    return {k: counts[k] for k in sorted(counts, key=int)}


# --- balance --------------------------------------------------------------------------------------


def wilson_interval(k: int, n: int, z: float = CONFIDENCE_Z) -> tuple[float, float]:
    """The Wilson score interval of the share k/n ((0, 1) when n is 0)."""
    if n == 0:
        return 0.0, 1.0
    p = k / n
    centre = p + z * z / (2 * n)
    spread = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return (centre - spread) / (1 + z * z / n), (centre + spread) / (1 + z * z / n)


def _check(check: str, what: str, counts: dict[str, int], threshold: float) -> dict:
    """One balance row: the most common item, its share, and a verdict.

    "warn": the share's 95 % lower bound is above the threshold (dominance beyond noise);
    "watch": the share is above it but within noise; "ok"; "no data".
    """
    n = sum(counts.values())
    if n == 0:
        return _no_data(check, what, threshold)
    item, k = max(counts.items(), key=lambda kv: (kv[1], kv[0]))
    share, (lower, upper) = k / n, wilson_interval(k, n)
    verdict = "warn" if lower > threshold else ("watch" if share > threshold else "ok")
    message = (f"{what}: {item} holds {share:.0%} ({k} of {n}; 95% lower bound {lower:.0%}), "
               f"threshold {threshold:.0%}")
    return _row(check, item, k, n, lower, upper, threshold, verdict, message)


def _step_check(stats: dict) -> dict:
    """The step count of the described questions furthest below the recipe's share for it.
    "warn": even the share's 95 % upper bound is under STEP_SHARE_MIN_RATIO of the wanted share."""
    from .questions.generate import STEPPED_FAMILIES

    what = "step counts of described questions"
    counts: Counter = Counter()
    for family in STEPPED_FAMILIES:
        counts.update(stats.get("steps_by_family", {}).get(family, {}))
    wanted = {k: w for k, w in stats["steps_wanted"].items() if w > 0}
    n = sum(counts.values())
    if n == 0:
        return _no_data("steps", what, 0.0)
    item = min(wanted, key=lambda s: (counts[s] / n / wanted[s], s))
    k, threshold = counts[item], round(STEP_SHARE_MIN_RATIO * wanted[item], 4)
    share, (lower, upper) = k / n, wilson_interval(k, n)
    verdict = "warn" if upper < threshold else ("watch" if share < threshold else "ok")
    label = f"{item} step" + ("" if item == "1" else "s")
    message = (f"{what}: {label} hold {share:.0%} ({k} of {n}; 95% upper bound {upper:.0%}) where the "
               f"recipe asks {wanted[item]:.0%}, threshold {threshold:.0%}")
    return _row("steps", label, k, n, lower, upper, threshold, verdict, message)


def _row(check: str, item, k: int, n: int, lower: float, upper: float, threshold: float, verdict: str,
         message: str) -> dict:
    return {"check": check, "item": item, "count": k, "total": n, "share": round(k / n, 4),
            "lower": round(lower, 4), "upper": round(upper, 4), "threshold": threshold, "verdict": verdict,
            "message": message}


def _no_data(check: str, what: str, threshold: float) -> dict:
    return {"check": check, "item": None, "count": 0, "total": 0, "share": 0.0, "lower": 0.0, "upper": 1.0,
            "threshold": threshold, "verdict": "no data", "message": f"{what}: no data"}


def answer_threshold(stats: dict, kind: str) -> float:
    """Fair share of the first letter plus ANSWER_MARGIN. Under uniform letters, (A) is the answer
    of 1/k of the questions with k options, so a kind mixing three and four boxes has a fair
    share between 1/4 and 1/3. Without option counts, the most options (default two) decide."""
    counts = {int(k): n for k, n in stats.get("answer_option_counts", {}).get(kind, {}).items() if int(k) >= 2}
    if counts:
        fair = sum(n / k for k, n in counts.items()) / sum(counts.values())
    else:
        fair = 1 / max(stats.get("answer_options", {}).get(kind, 2), 2)
    return round(fair + ANSWER_MARGIN, 4)


def balance_checks(stats: dict) -> list[dict]:
    """Every balance check on a stats dict (as ``collect`` returns or a crafted one)."""
    rows = [_check("predicate", "QA predicates", stats["qa_predicates"], PREDICATE_SHARE_MAX)]
    for kind, counts in stats.get("answers_by_kind", {}).items():
        rows.append(_check(f"answer:{kind}", f"{kind} answers", counts, answer_threshold(stats, kind)))
    grid3 = stats.get("answer_points", {}).get("grid3", [[0] * 3] * 3)
    cells = {f"{r}{c} cell": grid3[i][j] for i, r in enumerate(("top", "middle", "bottom"))
             for j, c in enumerate(("-left", "-centre", "-right"))}
    rows.append(_check("region", "answer points per 3x3 image cell", cells, REGION_SHARE_MAX))
    if stats.get("steps_wanted"):
        rows.append(_step_check(stats))
    rows.append(_predicate_floor_check(stats))
    return rows


def _predicate_floor_check(stats: dict) -> dict:
    """The rarest of the registered predicates, as a share of all QA. "warn": even the share's
    95 % upper bound is under the floor (1 % for a mix of recipes, 0.5 % for one)."""
    what = "rarest predicate in QA"
    n = stats.get("qa", 0)
    if not n:
        return _no_data("predicate floor", what, PREDICATE_FLOOR_SINGLE)
    threshold = PREDICATE_FLOOR_MIXED if " + " in str(stats.get("recipe", "")) else PREDICATE_FLOOR_SINGLE
    counts = {p: stats["qa_predicates"].get(p, 0) for p in predicate_families()}
    item = min(counts, key=lambda p: (counts[p], p))
    k = counts[item]
    share, (lower, upper) = k / n, wilson_interval(k, n)
    verdict = "warn" if upper < threshold else ("watch" if share < threshold else "ok")
    message = (f"{what}: {item} in {share:.1%} of QA ({k} of {n}; 95% upper bound {upper:.1%}), "
               f"floor {threshold:.1%}")
    return _row("predicate floor", item, k, n, lower, upper, threshold, verdict, message)


def format_text(stats: dict) -> str:
    lines = [
        f"scenes {stats['scenes']}  records {stats['records']}  QA {stats['qa']}  "
        f"({stats['qa_per_record']} per record)  shards {stats['shards']}",
        f"rejected scenes {stats['rejected']['count']} (rate {stats['rejected']['rate']:.1%})"
        + "".join(f"  {k}: {v}" for k, v in stats["rejected"]["reasons"].items()),
    ]
    for title, key in (("QA per family", "families"), ("QA per kind", "kinds"), ("QA per step count", "steps"),
                       ("QA per predicate", "qa_predicates"), ("true relations per predicate", "relation_predicates"),
                       ("choice answers", "answers"), ("objects per category", "categories"),
                       ("objects per colour", "colors"), ("records by object count", "objects_per_record"),
                       ("objects by visibility", "visibility_status")):
        lines.append(f"{title}:")
        counts = stats[key]
        total = sum(counts.values()) or 1
        lines.extend(f"  {k:<24} {v:>8}  {v / total:6.1%}" for k, v in counts.items())
    if "images" in stats:
        lines.extend(format_images(stats["images"]))
    lines.extend([f"warning: {w}" for w in stats.get("warnings", [])] or [NO_WARNINGS])
    lines.extend(f"warning: {w}" for w in stats.get("integrity", []))
    return "\n".join(lines)
