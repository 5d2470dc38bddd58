"""Where the time goes when K worker processes run at once (one GPU or CPU rasteriser shared).

    python benchmarks/concurrency_bench.py [--workers 1 8 16] [--scenes 8] [--recipe tabletop]

For each K, K spawned processes warm up (imports, GL context, texture and shape banks), wait at a barrier,
then each writes one shard of --scenes scenes with the real shard code. Printed per K: records/s
of all K together (records over the slowest worker's wall time, start-up excluded) and each
stage's mean ms per record across the workers. A stage whose cost grows with K is contended:
render for the GPU or rasteriser, every stage alike for cores, memory bandwidth or threads.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import tempfile
import time
from pathlib import Path

STAGES_AND_WRITE = ("compose", "physics", "camera", "render", "relations", "questions", "write+other")


def _worker(k: int, n: int, recipe_name: str, out: str, barrier, results) -> None:
    os.environ.setdefault("MUJOCO_GL", "egl")
    os.environ["LP_NUM_THREADS"] = "1"
    from refspatial.assets import load_catalogue
    from refspatial.pipeline import generate_scene, warm_banks
    from refspatial.recipe import load_recipe
    from refspatial.seeding import scene_seed
    from refspatial.shards import ShardJob, run_shard

    recipe, catalogue = load_recipe(recipe_name), load_catalogue()
    generate_scene(recipe, catalogue, scene_seed(1, k))  # GL context, first-call costs
    warm_banks(recipe, catalogue)
    job = ShardJob(k, k * n, (k + 1) * n, Path(out), recipe, catalogue, base_seed=0)
    barrier.wait()
    start = time.perf_counter()
    summary = run_shard(job)
    wall = time.perf_counter() - start
    seconds = dict(summary["seconds"])
    seconds["write+other"] = wall - sum(seconds.values())
    results.put((k, wall, summary["records"], seconds))


def run(workers: int, n: int, recipe: str) -> None:
    ctx = mp.get_context("spawn")  # GL contexts do not survive fork
    barrier, results = ctx.Barrier(workers), ctx.Queue()
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "shards").mkdir()
        procs = [ctx.Process(target=_worker, args=(k, n, recipe, tmp, barrier, results)) for k in range(workers)]
        for p in procs:
            p.start()
        got = [results.get() for _ in procs]
        for p in procs:
            p.join()
    walls = [g[1] for g in got]
    records = sum(g[2] for g in got)
    per_stage = {s: 1000 * sum(g[3].get(s, 0.0) for g in got) / records for s in STAGES_AND_WRITE}
    print(f"K={workers:3d}: {records / max(walls):7.2f} records/s together, "
          f"{1000 * sum(walls) / records:6.1f} ms/record/worker | " +
          "  ".join(f"{s} {v:.1f}" for s, v in per_stage.items()), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--scenes", type=int, default=8, help="scenes per worker")
    parser.add_argument("--recipe", default="tabletop")
    args = parser.parse_args()
    print(f"{os.cpu_count()} cores, MUJOCO_GL={os.environ.get('MUJOCO_GL', 'egl')}, "
          f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS')}, OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}")
    for k in args.workers:
        run(k, args.scenes, args.recipe)


if __name__ == "__main__":
    main()
