"""Where the CPU-side stages' time goes, in this process's CPU time, finer than bench.py's table.

    python benchmarks/cpu_profile.py [--scenes 12] [--recipe tabletop] [--passes 3]

bench.py times its stages by the wall clock, which any other job on the machine inflates (a
session's reads made every stage five times slower there). This counts the CPU time of this
process alone (``time.process_time``), pinned to one core with Mesa's rasteriser single-threaded
and the garbage collector set as every worker runs, and keeps the fastest of several passes over
the same seeds. Besides the pipeline's own stages and the shard write, it splits the two largest:
relations (the per-view facts, the free-space entries stored with every record, the other
predicates) and questions (by family). Both start warm, like bench.py: every texture image and
shape variant is made first.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ["LP_NUM_THREADS"] = "1"

import refspatial.pipeline as pipeline  # noqa: E402
import refspatial.questions.generate as question_draws  # noqa: E402
from refspatial.assets import load_catalogue  # noqa: E402
from refspatial.compose import SceneRejected  # noqa: E402
from refspatial.questions import questions_for_view  # noqa: E402
from refspatial.recipe import load_recipe  # noqa: E402
from refspatial.records import ShardWriter  # noqa: E402
from refspatial.relations import computed_relations, view_facts  # noqa: E402
from refspatial.relations import _free_space_entries as free_space_entries  # noqa: E402
from refspatial.relations.facts import posed_shapes  # noqa: E402
from refspatial.relations.geometry import forget_shared  # noqa: E402
from refspatial.render import render_views  # noqa: E402
from refspatial.seeding import scene_seed, stage_rng  # noqa: E402
from refspatial.shard_job import rarer_collections  # noqa: E402


class Clock:
    """CPU seconds per named part, summed over one pass."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}

    def time(self, part: str, fn, *args):
        start = time.process_time()
        try:
            return fn(*args)
        finally:
            self.seconds[part] = self.seconds.get(part, 0.0) + time.process_time() - start


def stages_pass(recipe, catalogue, seeds: list[int], out: Path) -> tuple[dict[str, float], int]:
    """The pipeline's stages (its own timers, reading CPU time) and the shard write, one pass."""
    clock, records = Clock(), 0
    forget_shared()
    # The garbage collector's setting while a worker makes a shard (run_shard's own).
    with rarer_collections(), ShardWriter(out, {"profile": {"recipe": recipe.name}}) as writer:
        for seed in seeds:
            outcome = pipeline.generate_scene(recipe, catalogue, seed)
            for stage, s in outcome.seconds.items():
                clock.seconds[stage] = clock.seconds.get(stage, 0.0) + s
            clock.time("write", lambda: [writer.write(r) for r in outcome.records])
            records += len(outcome.records)
    return clock.seconds, records


def detail_pass(recipe, rendered: list) -> tuple[dict[str, float], int]:
    """Relations split into its parts, and questions by family, over scenes rendered beforehand."""
    clock, records = Clock(), 0
    forget_shared()
    draws = dict(question_draws.FAMILIES)
    for name, draw in draws.items():  # each family's draws timed where the driver calls them
        question_draws.FAMILIES[name] = (lambda n, d: lambda *a: clock.time(f"questions: {n}", d, *a))(name, draw)
    try:
        for scene, views in rendered:
            shapes = clock.time("relations: posed shapes", posed_shapes, scene)
            seen = clock.time("relations: view facts", lambda: [view_facts(scene, v, shapes) for v in views])
            _, facts = clock.time("relations: record round trip", pipeline.stored_facts, scene, views, seen)
            clock.time("relations: free-space entries", lambda: [free_space_entries(f, f.askable()) for f in facts])
            clock.time("relations: other predicates", lambda: [computed_relations(f) for f in facts])
            for i, f in enumerate(facts):
                rng = stage_rng(recipe.hash, scene.seed, f"questions/{views[i].camera.name}")
                other = (f"other{i}", facts[i - 1]) if len(facts) > 1 else None
                clock.time("questions: all", questions_for_view, f, recipe["questions"], rng, f"view{i}", other)
            records += len(views)
    finally:
        question_draws.FAMILIES.update(draws)
    return clock.seconds, records


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenes", type=int, default=12)
    parser.add_argument("--recipe", default="tabletop")
    parser.add_argument("--passes", type=int, default=3, help="passes over the same seeds; the fastest counts")
    args = parser.parse_args()
    if args.scenes < 1 or args.passes < 1:
        sys.exit("cpu_profile: --scenes and --passes must be at least 1")
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    pipeline.STAGE_CLOCK = time.process_time
    recipe, catalogue = load_recipe(args.recipe), load_catalogue()
    pipeline.generate_scene(recipe, catalogue, scene_seed(1, 0))  # GL context and first-call costs
    pipeline.warm_banks(recipe, catalogue)
    seeds = [scene_seed(0, i) for i in range(args.scenes)]

    best: dict[str, float] = {}
    passes: list[float] = []  # CPU-side ms a record of each pass: the first pays first-use costs
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.passes):
            seconds, records = stages_pass(recipe, catalogue, seeds, Path(tmp) / f"pass{k}.mcap")
            passes.append(sum(s for part, s in seconds.items() if part != "render") * 1000 / records)
            for part, s in seconds.items():
                best[part] = min(best.get(part, float("inf")), 1000 * s / records)
    rendered = []
    for seed in seeds:
        try:
            scene = pipeline.build_scene(recipe, catalogue, seed)
        except SceneRejected:
            continue
        rendered.append((scene, render_views(scene, catalogue.materials)))
    detail: dict[str, float] = {}
    for _ in range(args.passes):
        seconds, n = detail_pass(recipe, rendered)
        for part, s in seconds.items():
            detail[part] = min(detail.get(part, float("inf")), 1000 * s / n)

    print(f"recipe {args.recipe}: {records} records from {args.scenes} scenes, one core, CPU time, "
          f"fastest of {args.passes} passes (ms a record)")
    cpu_side = [p for p in best if p != "render"]
    for part in (*pipeline.STAGES, "write"):
        if part in best:
            print(f"  {part:34s} {best[part]:7.1f}")
    print(f"  {'CPU-side stages (all but render)':34s} {sum(best[p] for p in cpu_side):7.1f}"
          f"   (each pass: {', '.join(f'{x:.1f}' for x in passes)})")
    print("split (the same scenes, rendered once beforehand):")
    for part in sorted(detail, key=lambda p: (p.split(":")[0], -detail[p])):
        print(f"  {part:34s} {detail[part]:7.2f}")


if __name__ == "__main__":
    main()
