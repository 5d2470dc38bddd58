"""What each realism feature costs the renderer: ms per view with one feature taken away at a time.

Scenes are built once (compose, physics, cameras); each variant renders the same views on one
core, after a warm-up pass of every variant, and keeps the faster of two timed passes, so the
numbers differ only by the feature removed.

    python benchmarks/realism_bench.py --scenes 8 [--recipe tabletop]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time

os.environ.setdefault("LP_NUM_THREADS", "1")  # one llvmpipe thread: per-core figures

from refspatial.assets import load_catalogue  # noqa: E402
from refspatial.compose import SceneRejected  # noqa: E402
from refspatial.pipeline import build_scene  # noqa: E402
from refspatial.recipe import load_recipe  # noqa: E402
from refspatial.render import render_views  # noqa: E402
from refspatial.seeding import scene_seed  # noqa: E402


def _hard(scene):
    return dataclasses.replace(scene, lights=tuple(dataclasses.replace(light, shadow_m=0.0) for light in scene.lights))


def _sun_only(scene):
    return dataclasses.replace(scene, lights=scene.lights[:1])


def _untextured(scene):
    objects = tuple(dataclasses.replace(o, asset=dataclasses.replace(o.asset, texture=None)) for o in scene.objects)
    return dataclasses.replace(scene, objects=objects)


def _no_props(scene):
    return dataclasses.replace(scene, room=dataclasses.replace(scene.room, props=()))


VARIANTS = {
    "full (default)": lambda s: s,
    "hard shadows (sun radius 0)": _hard,
    "sun only (no lamps)": _sun_only,
    "objects untextured": _untextured,
    "no background furniture": _no_props,
    "none of the above": lambda s: _no_props(_untextured(_sun_only(_hard(s)))),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=8)
    ap.add_argument("--recipe", default="tabletop")
    ap.add_argument("--seed", type=int, default=2026)
    args = ap.parse_args()
    catalogue, recipe = load_catalogue(), load_recipe(args.recipe)
    scenes, k = [], 0
    while len(scenes) < args.scenes:
        try:
            scenes.append(build_scene(recipe, catalogue, scene_seed(args.seed, k)))
        except SceneRejected:
            pass
        k += 1
    views = sum(len(s.cameras) for s in scenes)
    for variant in VARIANTS.values():  # warm-up: llvmpipe compiles a shader per state the first time it meets it
        for scene in scenes:
            render_views(variant(scene), catalogue.materials)
    print(f"{args.recipe}: {len(scenes)} scenes, {views} views, {scenes[0].cameras[0].width}x"
          f"{scenes[0].cameras[0].height}, one core")
    for name, variant in VARIANTS.items():
        best = float("inf")
        for _ in range(2):  # the faster of two passes: the machine's other work only ever adds time
            start = time.perf_counter()
            for scene in scenes:
                render_views(variant(scene), catalogue.materials)
            best = min(best, time.perf_counter() - start)
        print(f"  {name:<30} {1000 * best / views:7.1f} ms/view")


if __name__ == "__main__":
    main()
