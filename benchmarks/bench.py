"""End-to-end throughput against bare MuJoCo rendering of the same views.

    python benchmarks/bench.py [--scenes 20] [--recipe tabletop] [--workers K] [--scaling-scenes N] [--families N]

1. End to end: the real shard code (compose, settle, frame, render, relations,
   questions, MCAP write) in this process, pinned to one core, into a temporary folder.
2. Bare render: for the same scenes, only what any MuJoCo renderer must do for a
   new scene (compile the model, upload it to the GL context, draw RGB, depth and
   segmentation of every view) at the same resolution and quality settings, on the
   same core.
3. Optionally N scenes with K worker processes on all cores (scaling).
4. Optionally (--families N) every other recipe end to end on one core, N scenes each.
5. Optionally (--library-assets N) the same scenes drawing half their objects from a synthetic
   asset library of N textured meshes (benchmarks/library_bench.py), against none.
The ratio of (1) to (2) says how close the pipeline runs to the renderer's limit.

Both (1) and (2) run on one core with Mesa's rasteriser single-threaded, as every worker of
`refspatial generate` runs: "per core" then means what it says (unpinned, llvmpipe would
spread one process's rendering over every core). Both start warm: one scene outside the
measured set is made first, so GL start-up and first-call costs are not counted in either, and
every texture image is made once (as a long run's per-process cache holds them all).
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ["LP_NUM_THREADS"] = "1"  # as in every worker process; read when the first GL context is made

import refspatial  # noqa: E402,F401
from refspatial.assets import load_catalogue  # noqa: E402
from refspatial.compose import SceneRejected  # noqa: E402
from refspatial.pipeline import STAGES, build_scene, generate_scene, warm_banks  # noqa: E402
from refspatial.recipe import available, load_recipe  # noqa: E402
from refspatial.render import PHASES, gl_info, render_views  # noqa: E402
from refspatial.seeding import scene_seed  # noqa: E402
from refspatial.shards import ShardJob, generate, run_shard  # noqa: E402


def end_to_end(recipe, catalogue, n: int, out: Path) -> tuple[float, dict]:
    job = ShardJob(0, 0, n, out, recipe, catalogue, base_seed=0)
    (out / "shards").mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    summary = run_shard(job)
    return time.perf_counter() - start, summary


def stage_memory(recipe, catalogue, n: int) -> dict[str, int]:
    """Peak bytes each stage allocates (Python and numpy, via tracemalloc) over n scenes. GL
    buffers and MuJoCo's C allocations are outside tracemalloc's view: see the process RSS."""
    peaks: dict[str, int] = {}
    tracemalloc.start()
    try:
        for i in range(n):
            outcome = generate_scene(recipe, catalogue, scene_seed(0, i))
            for stage, b in outcome.peak_bytes.items():
                peaks[stage] = max(peaks.get(stage, 0), b)
    finally:
        tracemalloc.stop()
    return peaks


def bare_scenes(recipe, catalogue, n: int) -> list:
    """The settled, framed scenes of the end-to-end run's seeds (rejected ones left out, as there)."""
    scenes = []
    for i in range(n):
        try:
            scenes.append(build_scene(recipe, catalogue, scene_seed(0, i)))
        except SceneRejected:
            continue
    return scenes


def bare_render(scenes: list, catalogue, timings: dict[str, float] | None = None) -> tuple[float, int]:
    start = time.perf_counter()
    views = sum(len(render_views(s, catalogue.materials, timings)) for s in scenes)
    return time.perf_counter() - start, views


def stage_seconds(summary: dict, e2e_s: float) -> dict[str, float]:
    """A shard's stage timers, with what the end-to-end time holds beyond them as write+other."""
    return dict(summary["seconds"], **{"write+other": e2e_s - sum(summary["seconds"].values())})


def cpu_side(stages: dict[str, float]) -> float:
    """Seconds of every stage but the render: issue 17's "CPU-side stages"."""
    return sum(s for stage, s in stages.items() if stage != "render")


def other_families(main_recipe, catalogue, n: int) -> None:
    """Every other recipe's stages, end to end on one core: a family's own costs can go wrong
    unseen by the main recipe's table (rooms' relations ran ten times too slow for two sessions)."""
    print(f"\nthe other recipes, end to end on one core, {n} scenes each (banks warmed first), ms a record:")
    for name in available():
        if name == main_recipe.name:
            continue
        recipe = load_recipe(name)
        warm_banks(recipe, catalogue)
        with tempfile.TemporaryDirectory() as tmp:
            e2e_s, summary = end_to_end(recipe, catalogue, n, Path(tmp))
        records = max(summary["records"], 1)
        stages = stage_seconds(summary, e2e_s)
        print(f"  {name:<16} {summary['records'] / e2e_s:5.2f} records/s  " + "  ".join(
            f"{stage} {1000 * stages.get(stage, 0.0) / records:.1f}" for stage in (*STAGES, "write+other"))
            + f"  | CPU-side {1000 * cpu_side(stages) / records:.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenes", type=int, default=20)
    parser.add_argument("--recipe", default="tabletop")
    parser.add_argument("--workers", type=int, default=0, help="also time a run with this many processes")
    parser.add_argument("--scaling-scenes", type=int, default=0,
                        help="scenes for the run with --workers (default: 24 per worker, so start-up does not dominate)")
    parser.add_argument("--library-assets", type=int, default=0,
                        help="also time generation drawing half its objects from a synthetic library of this many assets")
    parser.add_argument("--library-scenes", type=int, default=0, help="scenes for that (default: --scenes)")
    parser.add_argument("--families", type=int, default=0,
                        help="also time this many scenes of every other recipe, end to end on one core")
    args = parser.parse_args()
    all_cores = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(all_cores)})
    recipe, catalogue = load_recipe(args.recipe), load_catalogue()
    cam = recipe["camera"]
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"python {platform.python_version()}, MUJOCO_GL={os.environ['MUJOCO_GL']}")
    gl = gl_info()
    print(f"GL: {gl['renderer']} ({gl['vendor']}, {gl['version']})")
    print(f"recipe {recipe.name}: {cam['width']}x{cam['height']}, {cam['views']} view(s)/scene, "
          f"{recipe['questions']['per_view']} QA/view wanted, {args.scenes} scenes")
    generate_scene(recipe, catalogue, scene_seed(1, 0))  # warm-up, outside the measured seeds
    # A long run's steady state: every texture image and shape variant made once per process, as
    # after a few hundred scenes (a 12-scene run would otherwise pay most of them inside the
    # measured set).
    start = time.perf_counter()
    images, shapes = warm_banks(recipe, catalogue)
    print(f"per-process texture and shape banks (warm-up, not measured below): {images} images, {shapes} shapes "
          f"({recipe.option('objects', 'shape_variants')} a category) in {time.perf_counter() - start:.2f} s")
    scenes = bare_scenes(recipe, catalogue, args.scenes)
    # Bare renders bracket the end-to-end run: a shared machine's speed drifts by tens of
    # per cent over a minute, and the ratio should not depend on which side the drift hit.
    before_s, views = bare_render(scenes, catalogue)
    with tempfile.TemporaryDirectory() as tmp:
        e2e_s, summary = end_to_end(recipe, catalogue, args.scenes, Path(tmp))
        size = (Path(tmp) / summary["file"]).stat().st_size
    records, qa = summary["records"], summary["qa"]
    print(f"\nend to end (1 process, 1 core): {e2e_s:.2f} s, {records} records, {qa} QA, "
          f"{len(summary['skipped'])} scenes rejected")
    print(f"  records/s {records / e2e_s:.2f}   QA/s {qa / e2e_s:.1f}   QA/record {qa / max(records, 1):.1f}   "
          f"shard bytes/record {size / max(records, 1) / 1e6:.2f} MB")
    stages = stage_seconds(summary, e2e_s)
    for stage in (*STAGES, "write+other"):
        s = stages.get(stage, 0.0)
        print(f"  {stage:<12} {s:7.2f} s  {100 * s / e2e_s:5.1f} %  {1000 * s / max(records, 1):7.1f} ms/record")
    print(f"  CPU-side stages (all but render): {1000 * cpu_side(stages) / max(records, 1):.1f} ms/record")
    peaks = stage_memory(recipe, catalogue, min(args.scenes, 4))
    print("\npeak memory allocated per stage (tracemalloc, first 4 scenes; GL and MuJoCo C memory not included):")
    print("  " + "   ".join(f"{stage} {peaks.get(stage, 0) / 2**20:.1f} MiB" for stage in STAGES))
    phases: dict[str, float] = {}
    after_s, _ = bare_render(scenes, catalogue, phases)
    bare_s = (before_s + after_s) / 2
    print(f"\nbare MuJoCo render of the same {views} views on the same core (model compile, MjrContext, colour pass and "
          f"depth+segmentation pass, GL context reused, as in the pipeline), before and after the end-to-end run: "
          f"{before_s:.2f} s and {after_s:.2f} s, mean {views / bare_s:.2f} views/s, {1000 * bare_s / views:.1f} ms/view")
    print("  where a view's render time goes (second bare run; read-backs wait for the GPU): " + "   ".join(
        f"{phase} {1000 * phases.get(phase, 0.0) / views:.1f} ms" for phase in PHASES))
    print(f"ratio end-to-end / bare render: {(records / e2e_s) / (views / bare_s):.2f}")
    if args.workers > 1:
        os.sched_setaffinity(0, all_cores)  # the workers inherit it
        n = args.scaling_scenes or 24 * args.workers
        with tempfile.TemporaryDirectory() as tmp:
            start = time.perf_counter()
            m = generate(Path(tmp), recipe, catalogue, n, 0, args.workers, scenes_per_shard=max(1, n // (2 * args.workers)))
            wall = time.perf_counter() - start
        print(f"\n{args.workers} worker processes on {len(all_cores)} cores, {n} scenes (start-up included): "
              f"{wall:.2f} s, {m['records'] / wall:.2f} records/s, {m['qa'] / wall:.1f} QA/s "
              f"(speed-up {(m['records'] / wall) / (records / e2e_s):.2f}x over one core)")
    if args.families > 0:
        os.sched_setaffinity(0, {min(all_cores)})
        other_families(recipe, catalogue, args.families)
    if args.library_assets > 0:
        from library_bench import run as library_run

        os.sched_setaffinity(0, {min(all_cores)})
        library_run(recipe, catalogue, args.library_assets, args.library_scenes or args.scenes, len(all_cores))
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\npeak RSS of this process: {peak:.0f} MB")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
