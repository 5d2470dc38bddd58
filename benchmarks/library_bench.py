"""What drawing from a big asset library costs: a synthetic library of N textured meshes is made
on the fly (upright cylinders of 512 triangles with their own 64x64 texture each, hull collision so
building it takes seconds, not CoACD's hours), imported with `assets import`, and the same
scenes are generated with and without it (share 0.5) on one core. The slowdown is measured on
records/s: the library's capsules are simpler than most procedural meshes, and a different
object set is rejected and rendered differently, so wall time alone would mislead.

The per-process cache starts cold, so every library asset a scene draws is read from disk and
checked (the worst case: a short run over a big library reads an asset for almost every draw).
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh
from PIL import Image

from refspatial.library import _geometry, attach
from refspatial.library_import import import_library
from refspatial.shards import ShardJob, run_shard


def synthetic_source(folder: Path, n: int) -> Path:
    """n textured GLB capsules of varied size, annotated in one annotations.jsonl."""
    rng = np.random.default_rng(0)
    rows = []
    for i in range(n):
        # Upright cylinders stand still once dropped (capsules rolled away and got scenes rejected).
        mesh = trimesh.creation.cylinder(radius=float(rng.uniform(15, 40)), height=float(rng.uniform(30, 120)),
                                         sections=128)
        v = mesh.vertices[mesh.faces].reshape(-1, 3)  # own corners per face: the uv seam needs no care
        mesh = trimesh.Trimesh(v, np.arange(len(v)).reshape(-1, 3), process=False)
        uv = np.column_stack([(np.arctan2(v[:, 1], v[:, 0]) / (2 * np.pi)) % 1.0, (v[:, 2] - v[:, 2].min()) / np.ptp(v[:, 2])])
        image = Image.fromarray(rng.integers(0, 256, (64, 64, 3), dtype=np.uint8))
        mesh.visual = trimesh.visual.TextureVisuals(uv=uv, image=image)
        name = f"m{i:05d}.glb"
        mesh.export(folder / name)
        rows.append({"file": name, "category": "toy", "name": "toy", "plural": "toys", "color": "red", "up": "+z",
                     "front": [1, 0, 0], "scale": 0.001, "licence": "CC0-1.0", "source": f"synthetic:{i}",
                     "collision": {"method": "hull"}})
    (folder / "annotations.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    return folder


def _shard(recipe, catalogue, n: int) -> tuple[float, dict]:
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "shards").mkdir()
        start = time.perf_counter()
        summary = run_shard(ShardJob(0, 0, n, Path(tmp), recipe, catalogue, base_seed=0))
        return time.perf_counter() - start, summary


def run(recipe, catalogue, n_assets: int, n_scenes: int, workers: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "src"
        src.mkdir()
        start = time.perf_counter()
        synthetic_source(src, n_assets)
        made = time.perf_counter() - start
        affinity = os.sched_getaffinity(0)
        os.sched_setaffinity(0, set(range(os.cpu_count() or 1)))  # the import pool may use every core
        start = time.perf_counter()
        summary = import_library(src, Path(tmp) / "lib", workers=workers, cache_dir=Path(tmp) / "cache")
        imported = time.perf_counter() - start
        os.sched_setaffinity(0, affinity)
        start = time.perf_counter()
        with_lib, lib_catalogue = attach(recipe, catalogue, [Path(tmp) / "lib"], 0.5)
        attach_s = time.perf_counter() - start
        print(f"\nasset library: {n_assets} synthetic textured meshes written in {made:.1f} s, imported with "
              f"{workers} workers in {imported:.1f} s ({summary.imported / imported:.1f} assets/s, "
              f"{len(summary.skipped)} skipped); index opened in {1000 * attach_s:.0f} ms")
        _shard(recipe, catalogue, 1)  # warm-up (GL context), outside the measure
        plain_s, plain = _shard(recipe, catalogue, n_scenes)
        _geometry.cache_clear()  # cold: every drawn asset is read and checked
        lib_s, lib = _shard(with_lib, lib_catalogue, n_scenes)
        warm_s, _ = _shard(with_lib, lib_catalogue, n_scenes)  # same scenes again: all drawn assets cached
    for label, s, summ in (("catalogue only", plain_s, plain), ("library, cold cache", lib_s, lib),
                           ("library, warm cache", warm_s, lib)):
        print(f"  {label:<20} {n_scenes} scenes: {s:6.2f} s, {summ['records'] / s:5.2f} records/s, "
              f"{len(summ['skipped'])} rejected, {s / n_scenes:.2f} s/scene, "
              f"compose {1000 * summ['seconds'].get('compose', 0) / n_scenes:6.1f} ms/scene"
              + ("" if summ is plain else ", slowdown (records/s) "
                                          f"{100 * (1 - (summ['records'] / s) / (plain['records'] / plain_s)):+.1f} %"))
