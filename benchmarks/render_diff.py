"""How far two renders of the same scenes differ: CPU (Mesa llvmpipe) against GPU (NVIDIA EGL).

    python benchmarks/render_diff.py CPU_DIR GPU_DIR [--panel worst.png]

Both folders must come from the same `refspatial generate` command (recipe, seed, scene count)
on the two machines. Records are matched by key. Per record it measures the RGB difference
(mean absolute, and the share of pixels whose largest channel difference passes 8 and 32
levels), the depth difference in millimetres where both images see a surface, the share of
pixels whose object id differs, and whether the relations and QA written from the two
renders are the same. ``--panel`` saves the worst record's two images and their difference
(amplified 4x) side by side.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from refspatial.data import load_manifest
from refspatial.records import ShardReader

FAR_M = 50.0  # depth beyond this is sky or void in both renders: nothing to compare


def records(root: Path) -> dict[str, dict]:
    out = {}
    for entry in load_manifest(root):
        for sample in ShardReader(entry.path).iter():
            out[sample["key"]] = sample
    return out


def compare(a: dict, b: dict) -> dict:
    rgb_a, rgb_b = a["rgb"].astype(np.int16), b["rgb"].astype(np.int16)
    step = np.abs(rgb_a - rgb_b).max(axis=2)
    both = (a["depth_m"] < FAR_M) & (b["depth_m"] < FAR_M)
    dz_mm = 1000 * np.abs(a["depth_m"][both].astype(np.float64) - b["depth_m"][both])
    return {
        "rgb_mean_abs": float(np.abs(rgb_a - rgb_b).mean()),
        "rgb_px_over_8": float((step > 8).mean()),
        "rgb_px_over_32": float((step > 32).mean()),
        "depth_median_mm": float(np.median(dz_mm)) if dz_mm.size else 0.0,
        "depth_p99_mm": float(np.percentile(dz_mm, 99)) if dz_mm.size else 0.0,
        "depth_px_over_10mm": float((dz_mm > 10).mean()) if dz_mm.size else 0.0,
        "seg_px_differ": float((a["seg"] != b["seg"]).mean()),
        "same_relations": a["relations"] == b["relations"],
        "same_qa": a["qa"] == b["qa"],
    }


def panel(a: dict, b: dict, path: Path) -> None:
    import cv2

    diff = np.clip(4 * np.abs(a["rgb"].astype(np.int16) - b["rgb"]), 0, 255).astype(np.uint8)
    row = np.concatenate([a["rgb"], b["rgb"], diff], axis=1)
    cv2.imwrite(str(path), cv2.cvtColor(row, cv2.COLOR_RGB2BGR))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("cpu", type=Path)
    parser.add_argument("gpu", type=Path)
    parser.add_argument("--panel", type=Path, help="save the worst record's CPU | GPU | 4x difference here")
    parser.add_argument("--json", action="store_true", help="print every record's numbers as JSON")
    args = parser.parse_args(argv)
    a, b = records(args.cpu), records(args.gpu)
    keys = sorted(set(a) & set(b))
    if not keys:
        print(f"error: {args.cpu} and {args.gpu} share no record keys; make both with the same "
              "`refspatial generate` command", file=sys.stderr)
        return 2
    rows = {k: compare(a[k], b[k]) for k in keys}
    if args.json:
        print(json.dumps(rows, indent=1))
    print(f"{len(keys)} records in both ({len(a)} CPU, {len(b)} GPU)")
    for name in ("rgb_mean_abs", "rgb_px_over_8", "rgb_px_over_32", "depth_median_mm", "depth_p99_mm",
                 "depth_px_over_10mm", "seg_px_differ"):
        v = np.array([r[name] for r in rows.values()])
        scale, unit = (100, " %") if "px" in name else (1, "")
        print(f"  {name:<20} mean {scale * v.mean():8.3f}{unit}   max {scale * v.max():8.3f}{unit}")
    for name in ("same_relations", "same_qa"):
        print(f"  {name:<20} {sum(r[name] for r in rows.values())} of {len(keys)} records")
    if args.panel:
        worst = max(keys, key=lambda k: rows[k]["rgb_mean_abs"])
        panel(a[worst], b[worst], args.panel)
        print(f"worst record {worst}: CPU | GPU | 4x |difference| in {args.panel}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
