"""Regenerate the golden dataset under tests/golden/ (run only when the format changes on purpose).

    python tests/golden/make_golden.py

Writes ``dataset/`` (manifest.json, one MCAP shard and its sidecar) and ``expected.json``:
what today's reader makes of the shard (summary schemas and channels, metadata, every
record's JSON content and array shapes). tests/test_golden.py checks that the committed
shard still reads to exactly that; a failure there means the shard format drifted, so bump
``format_version`` (shards.FORMAT_VERSION) and describe the change in docs/FORMAT.md before
regenerating.
"""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import refspatial  # noqa: F401  (sets MUJOCO_GL before mujoco loads)
from refspatial.assets import load_catalogue
from refspatial.recipe import load_recipe
from refspatial.records import ShardReader
from refspatial.shards import generate

HERE = Path(__file__).resolve().parent
SEED = 15  # a seed whose two views ask every question family between them (re-pick when regenerating)


def describe(shard: Path) -> dict:
    """The facts the golden test pins: summary, metadata and every record's content."""
    from mcap.reader import make_reader

    with open(shard, "rb") as f:
        summary = make_reader(f).get_summary()
    schemas = {s.id: s for s in summary.schemas.values()}
    channels = sorted(
        ({"topic": c.topic, "message_encoding": c.message_encoding, "metadata": dict(c.metadata),
          "schema_name": schemas[c.schema_id].name, "schema_encoding": schemas[c.schema_id].encoding}
         for c in summary.channels.values()), key=lambda c: c["topic"])
    reader = ShardReader(shard)
    records = []
    for s in reader:
        records.append({
            "key": s["key"], "index": s["index"], "scene": s["scene"], "relations": s["relations"],
            "qa": s["qa"], "K": s["K"].tolist(), "T_world_cam": s["T_world_cam"].tolist(),
            "shapes": {k: [list(s[k].shape), str(s[k].dtype)] for k in ("rgb", "depth_m", "seg")},
        })
    return {"channels": channels, "metadata": reader.metadata(), "records": records}


def main() -> int:
    out = HERE / "dataset"
    shutil.rmtree(out, ignore_errors=True)
    recipe = load_recipe(str(HERE / "golden.yaml"))
    generate(out, recipe, load_catalogue(), n_scenes=1, base_seed=SEED, workers=1, scenes_per_shard=1)
    expected = describe(out / "shards" / "shard-00000.mcap")
    if not expected["records"]:
        print(f"seed {SEED} made no records; pick another SEED", file=sys.stderr)
        return 1
    text = json.dumps(expected, indent=1, sort_keys=True, ensure_ascii=False)
    (HERE / "expected.json").write_text(text + "\n", encoding="utf-8")
    size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    print(f"wrote {out} ({size / 1e3:.0f} kB, {len(expected['records'])} records)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
