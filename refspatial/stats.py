"""Dataset statistics for audits: what was generated, and how it is spread.

Reads only the JSON topics of each record (no image is decoded), so it stays
fast on large datasets.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

from .records import ShardReader


def load_manifest(root: Path) -> dict:
    path = Path(root) / "manifest.json"
    if not path.is_file():
        raise FileNotFoundError(f"{path} not found; pass the folder that `refspatial generate --out` wrote")
    return json.loads(path.read_text(encoding="utf-8"))


def collect(root: Path) -> dict:
    manifest = load_manifest(root)
    c = {name: Counter() for name in ("qa_predicates", "relation_predicates", "steps", "families", "kinds",
                                       "categories", "colors", "objects_per_record", "answers")}
    for shard in manifest["shards"]:
        for sample in ShardReader(Path(root) / shard["file"]).iter(fields=()):
            objects = sample["scene"]["objects"]
            c["objects_per_record"][len(objects)] += 1
            c["categories"].update(o["category"] for o in objects)
            c["colors"].update(o["color"] for o in objects)
            c["relation_predicates"].update(r["predicate"] for r in sample["relations"])
            for qa in sample["qa"]:
                c["families"][qa["family"]] += 1
                c["kinds"][qa["kind"]] += 1
                c["steps"][qa["num_steps"]] += 1
                c["qa_predicates"].update(qa["predicates"])
                if qa["kind"] != "point":
                    c["answers"][qa["answer"]] += 1
    return {
        "scenes": manifest["scenes"],
        "records": manifest["records"],
        "qa": manifest["qa"],
        "shards": len(manifest["shards"]),
        "rejected": {k: manifest["rejected"][k] for k in ("count", "rate", "reasons")},
        "qa_per_record": round(manifest["qa"] / manifest["records"], 2) if manifest["records"] else 0.0,
        **{name: _sorted(counter) for name, counter in c.items()},
    }


def _sorted(counter: Counter) -> dict:
    return {str(k): v for k, v in sorted(counter.items(), key=lambda kv: (-kv[1], str(kv[0])))}


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
                       ("objects per colour", "colors"), ("records by object count", "objects_per_record")):
        lines.append(f"{title}:")
        counts = stats[key]
        total = sum(counts.values()) or 1
        lines.extend(f"  {k:<24} {v:>8}  {v / total:6.1%}" for k, v in counts.items())
    return "\n".join(lines)
