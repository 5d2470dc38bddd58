"""Whether two datasets hold the same records, whatever their shards' bytes.

    python benchmarks/same_records.py DATASET_A DATASET_B

For a change that alters how records are encoded but not what they hold (an image codec's
framing, a JSON writer's number spelling), comparing sha256 sums says nothing. This reads every
shard of both datasets back through ``ShardReader`` and compares what a trainer gets: keys, the
scene, relation and QA documents, K and the camera pose, every RGB, depth and segmentation pixel
(depth bit for bit), and the shards' metadata. The manifests and shard summaries must match too,
apart from the shard files' own checksums. Exit status 1 on any
difference, with the first few named.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from refspatial.records import ShardReader

# The field of the manifest's shard list and of the shard summaries that describes a shard
# file's bytes, not its records (``catalogue_sha256`` names the catalogue, and must match).
BYTE_FIELDS = {"sha256"}
MAX_REPORTED = 10


def _without_bytes(obj):
    if isinstance(obj, dict):
        return {k: _without_bytes(v) for k, v in obj.items() if k not in BYTE_FIELDS}
    if isinstance(obj, list):
        return [_without_bytes(v) for v in obj]
    return obj


def _same_array(a: np.ndarray, b: np.ndarray) -> bool:
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    if a.dtype.kind == "f":  # bit for bit, NaN included
        return np.array_equal(a.view(f"u{a.itemsize}"), b.view(f"u{b.itemsize}"))
    return np.array_equal(a, b)


def compare(a: Path, b: Path) -> tuple[int, list[str]]:
    """(records compared, differences) between datasets ``a`` and ``b``."""
    problems: list[str] = []
    files_a = sorted(p.relative_to(a) for p in a.rglob("*") if p.suffix in (".mcap", ".json"))
    files_b = sorted(p.relative_to(b) for p in b.rglob("*") if p.suffix in (".mcap", ".json"))
    if files_a != files_b:
        problems.append(f"different files: {sorted(set(map(str, files_a)) ^ set(map(str, files_b)))}")
    records = 0
    for rel in sorted(set(files_a) & set(files_b)):
        if rel.suffix == ".json":
            ja, jb = (json.loads((root / rel).read_text()) for root in (a, b))
            if _without_bytes(ja) != _without_bytes(jb):
                problems.append(f"{rel}: documents differ beyond the shard files' checksums")
            continue
        ra, rb = ShardReader(a / rel), ShardReader(b / rel)
        if len(ra) != len(rb):
            problems.append(f"{rel}: {len(ra)} against {len(rb)} records")
            continue
        if ra.metadata() != rb.metadata():
            problems.append(f"{rel}: metadata differ")
        for i, (x, y) in enumerate(zip(ra.iter(), rb.iter())):
            records += 1
            for field in ("key", "index", "scene", "relations", "qa"):
                if x[field] != y[field]:
                    problems.append(f"{rel} record {i}: {field} differs")
            for field in ("K", "T_world_cam", "rgb", "depth_m", "seg"):
                if not _same_array(x[field], y[field]):
                    problems.append(f"{rel} record {i}: {field} differs")
    return records, problems


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("a", type=Path)
    parser.add_argument("b", type=Path)
    args = parser.parse_args()
    for root in (args.a, args.b):
        if not root.is_dir():
            print(f"same_records: {root} is not a folder; give two dataset folders", file=sys.stderr)
            sys.exit(2)
    records, problems = compare(args.a, args.b)
    for p in problems[:MAX_REPORTED]:
        print(p)
    if problems:
        print(f"{len(problems)} differences over {records} records")
        sys.exit(1)
    print(f"same records: {records} compared, every field equal")


if __name__ == "__main__":
    main()
