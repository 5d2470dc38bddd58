"""Count the instructions two checkouts spend on the relation and question stages (cachegrind).

    python benchmarks/instructions.py BEFORE_DIR AFTER_DIR [--recipe tabletop] [--scenes 4]

On this shared machine the same code's CPU time moves by a tenth within minutes, and even
``ab_pair.py`` (both checkouts at once, cores swapped) read +15 % and -5.7 % for one change in
one hour: a change worth 1 % cannot be seen by any clock here. Instructions can: valgrind's
cachegrind counts every instruction a process executes, and with the hash seed, the address
layout and the thread counts fixed (PYTHONHASHSEED=0, ``setarch -R``, one OpenBLAS and OpenCV
thread) three runs of the same code agreed to 4,000 instructions in 8.9 billion, and the same
code in two checkout folders, or with one more module imported, within 0.03 %. Instructions are
not time (a cache miss costs more than an add), but a change that only removes Python and numpy
work shows there as it would in time.

The scenes are composed, settled and rendered once, natively, by this environment's checkout and
handed to both sides as a pickle (rendering under valgrind would take hours), so both count the
same relations and questions of the same views: view facts, the record's round trip, the relation
table and every question. Each checkout first runs once under cachegrind uncounted (Python's
bytecode cache, and numba's machine code for valgrind's virtual CPU, are written then), then
counted over one scene more than asked, next to a run over that first scene alone; the
difference is the stages' count for the scenes after the first. A worker pays what happens once
per process (numba loading a compiled loop's machine code: 67 million instructions for one loop,
8 million a record over eight records) once in hundreds of records, so the first scene, which
pays it here, is left out of both counts. Needs valgrind (``apt-get install valgrind``); about
eight minutes for four tabletop scenes after the first (each checkout's runs two at a time).
"""

from __future__ import annotations

import argparse
import os
import pickle
import re
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

# Run by each checkout's own Python path: the stages of pipeline.generate_scene after rendering.
WORK = """
import pickle, sys
import refspatial.pipeline as pipeline
from refspatial.questions import questions_for_view
from refspatial.recipe import load_recipe
from refspatial.relations import computed_relations, view_facts
from refspatial.relations.facts import posed_shapes
from refspatial.seeding import stage_rng
from refspatial.shard_job import rarer_collections
name, rendered = pickle.load(open(sys.argv[1], "rb"))
recipe, n = load_recipe(name), int(sys.argv[2])
# A worker's shape bank keeps each mesh's box and volume once made; the unpickled meshes are new, so
# they are made here, in the loading that every count subtracts, not in the stages counted.
for scene, _ in rendered:
    for obj in scene.objects:
        obj.asset.visual.bounds_m, obj.asset.visual.volume_m3
with rarer_collections():  # the garbage collector as a worker sets it
    for scene, views in rendered[:n]:
        shapes = posed_shapes(scene)
        _, facts = pipeline.stored_facts(scene, views, [view_facts(scene, v, shapes) for v in views])
        [computed_relations(f) for f in facts]
        keys = [f"{scene.scene_id}/{v.camera.name}" for v in views]
        for i, f in enumerate(facts):
            rng = stage_rng(recipe.hash, scene.seed, f"questions/{views[i].camera.name}")
            other = (keys[i - 1], facts[i - 1]) if len(views) > 1 else None
            questions_for_view(f, recipe["questions"], rng, keys[i], other)
"""


def render(recipe_name: str, scenes: int, out: Path) -> int:
    """Compose, settle and render ``scenes`` scenes (seeds of base seed 0) into a pickle; returns
    how many records the scenes after the first make (rejected scenes are left out)."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    from refspatial import pipeline
    from refspatial.assets import load_catalogue
    from refspatial.compose import SceneRejected
    from refspatial.recipe import load_recipe
    from refspatial.render import render_views
    from refspatial.seeding import scene_seed

    recipe, catalogue, rendered = load_recipe(recipe_name), load_catalogue(), []
    for i in range(scenes):
        try:
            scene = pipeline.build_scene(recipe, catalogue, scene_seed(0, i))
        except SceneRejected:
            continue
        rendered.append((scene, render_views(scene, catalogue.materials)))
    out.write_bytes(pickle.dumps((recipe_name, rendered)))
    return sum(len(views) for _, views in rendered[1:])


def count(tree: Path, script: Path, data: Path, scenes: int) -> int:
    """Instructions of one run of the stages over the first ``scenes`` scenes."""
    # One thread everywhere: under valgrind, idle OpenBLAS and OpenCV threads spin for a varying
    # number of instructions (runs differed by 0.2-1 %; alone, by a few thousand instructions).
    env = dict(os.environ, PYTHONPATH=str(tree), PYTHONHASHSEED="0", LP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1",
               OMP_NUM_THREADS="1", OPENCV_FOR_THREADS_NUM="1", NUMBA_NUM_THREADS="1")
    command = ["setarch", os.uname().machine, "-R", "valgrind", "--tool=cachegrind", "--cache-sim=no",
               "--cachegrind-out-file=/dev/null", sys.executable, str(script), str(data), str(scenes)]
    done = subprocess.run(command, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"instructions: the run in {tree} failed:\n{done.stderr[-2000:]}")
    found = re.search(r"I\s+refs:\s+([\d,]+)", done.stderr)
    if found is None:
        sys.exit(f"instructions: no instruction count in valgrind's output:\n{done.stderr[-2000:]}")
    return int(found.group(1).replace(",", ""))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("before", type=Path)
    parser.add_argument("after", type=Path)
    parser.add_argument("--recipe", default="tabletop")
    parser.add_argument("--scenes", type=int, default=4)
    parser.add_argument("--runs", type=int, default=1, help="counted runs of each checkout (they agree to a few "
                        "thousand instructions)")
    args = parser.parse_args()
    for tree in (args.before, args.after):
        if not (tree / "refspatial" / "__init__.py").is_file():
            print(f"instructions: {tree} is not a refspatial checkout; give two checkout folders", file=sys.stderr)
            sys.exit(2)
    if args.scenes < 1 or args.runs < 1:
        print("instructions: --scenes and --runs must be at least 1", file=sys.stderr)
        sys.exit(2)
    if shutil.which("valgrind") is None or shutil.which("setarch") is None:
        print("instructions: needs valgrind and setarch; install them with `apt-get install valgrind`", file=sys.stderr)
        sys.exit(2)
    with tempfile.TemporaryDirectory() as tmp:
        data, script = Path(tmp) / "views.pkl", Path(tmp) / "stages.py"
        script.write_text(WORK)
        records = render(args.recipe, args.scenes + 1, data)
        trees = {"before": args.before.resolve(), "after": args.after.resolve()}
        with ThreadPoolExecutor(2) as pool:
            # Bytecode and numba's machine code are cached by a first run under valgrind, not
            # counted: valgrind's virtual CPU lacks some of this one's instructions (AVX-512),
            # so numba compiles its loops for it again, once (about 5 billion instructions).
            list(pool.map(lambda tree: count(tree, script, data, args.scenes + 1), trees.values()))
            jobs = {(side, k): pool.submit(count, tree, script, data, args.scenes + 1)
                    for k in range(args.runs) for side, tree in trees.items()}
            first = {side: pool.submit(count, tree, script, data, 1) for side, tree in trees.items()}
            counts = {key: job.result() for key, job in jobs.items()}
            base = {side: job.result() for side, job in first.items()}
    print(f"recipe {args.recipe}: {records} records from {args.scenes} scenes; instructions of the relation and "
          f"question stages (each run less a run over the first scene alone), millions a record:")
    stages = {}
    for side in trees:
        runs = [(counts[(side, k)] - base[side]) / records / 1e6 for k in range(args.runs)]
        stages[side] = sum(runs) / len(runs)
        print(f"  {side:7s} {' '.join(f'{r:9.2f}' for r in runs)}")
    print(f"  change: {100 * (stages['after'] / stages['before'] - 1):+.2f} %")


if __name__ == "__main__":
    main()
