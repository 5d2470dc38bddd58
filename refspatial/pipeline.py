"""One scene, end to end: compose -> settle -> frame -> render -> relations -> questions.

``generate_scene`` is a pure function of (recipe, catalogue, seed) apart from the
GL rendering inside; it returns records ready for a shard, or the reason the
scene was rejected, plus the time spent in each stage (for ``make bench``).
"""

from __future__ import annotations

import time
import tracemalloc
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Iterator

from .assets import Catalogue
from .camera import frame_cameras
from .compose import SceneRejected, compose
from .physics import settle
from .questions import questions_for_view
from .recipe import Recipe
from .records import Record
from .relations import ViewFacts, computed_relations, view_facts
from .relations.facts import posed_shapes
from .relations.masks import PIXELS_KEY, cached_boxes
from .relations.stored import facts_from_record, object_record, rounded
from .render import View, render_views
from .scene import Light, Room, Scene
from .seeding import stage_rng

# What stage timings read: the wall clock, as a run's statistics report it; a profile of CPU work
# alone (benchmarks/cpu_profile.py) sets time.process_time.
STAGE_CLOCK = time.perf_counter
STAGES = ("compose", "physics", "camera", "render", "relations", "questions")


@dataclass
class SceneOutcome:
    seed: int
    records: list[Record] = field(default_factory=list)
    rejected: str | None = None  # reason slug
    detail: str = ""
    seconds: dict[str, float] = field(default_factory=dict)
    # Per stage, the most Python/numpy memory it held above what was held when it began; only
    # while tracemalloc traces (make bench turns it on for a short run; it slows everything).
    peak_bytes: dict[str, int] = field(default_factory=dict)


@contextmanager
def _timed(seconds: dict[str, float], stage: str, peaks: dict[str, int] | None = None) -> Iterator[None]:
    tracing = peaks is not None and tracemalloc.is_tracing()
    if tracing:
        tracemalloc.reset_peak()
        held = tracemalloc.get_traced_memory()[0]
    start = STAGE_CLOCK()
    try:
        yield
    finally:
        seconds[stage] = seconds.get(stage, 0.0) + STAGE_CLOCK() - start
        if tracing:
            peaks[stage] = max(peaks.get(stage, 0), tracemalloc.get_traced_memory()[1] - held)


def build_scene(recipe: Recipe, catalogue: Catalogue, seed: int, seconds: dict[str, float] | None = None,
                peaks: dict[str, int] | None = None) -> Scene:
    """The composed, settled scene with its cameras framed (raises SceneRejected)."""
    seconds = {} if seconds is None else seconds
    with _timed(seconds, "compose", peaks):
        scene = compose(recipe, catalogue, seed)
    with _timed(seconds, "physics", peaks):
        scene = settle(scene, catalogue.materials, recipe)
    with _timed(seconds, "camera", peaks):
        scene = frame_cameras(scene, recipe)
    return scene


def warm_banks(recipe: Recipe, catalogue: Catalogue) -> tuple[int, int]:
    """Make every texture image and shape variant the recipe can ask for into this process's
    banks, and the variants' meshes into MuJoCo's compiler cache, as a long run has after a few
    hundred scenes, and return how many images and shapes. For benchmarks that measure that
    steady state; records are the same with or without it."""
    from .assets import build_variants
    from .compose import category_pool
    from .looks import load_looks, texture_bank
    from .mjcf import warm_mesh_cache

    images = texture_bank(load_looks(), catalogue.categories, catalogue.colors)
    variants = recipe.option("objects", "shape_variants")
    pool = category_pool(recipe, catalogue)
    if recipe.option("furniture", "count")[1] > 0:
        pool += category_pool(recipe, catalogue, "furniture")
    shapes = build_variants(catalogue, pool, variants) if variants else []
    warm_mesh_cache(part for parts in shapes for part in parts)
    return images, len(shapes)


def generate_scene(recipe: Recipe, catalogue: Catalogue, seed: int) -> SceneOutcome:
    out = SceneOutcome(seed)
    try:
        scene = build_scene(recipe, catalogue, seed, out.seconds, out.peak_bytes)
    except SceneRejected as exc:
        out.rejected, out.detail = exc.reason, str(exc)
        return out
    with _timed(out.seconds, "render", out.peak_bytes):
        views = render_views(scene, catalogue.materials)
    with _timed(out.seconds, "relations", out.peak_bytes):
        shapes = posed_shapes(scene)  # the same in every view
        described, facts = stored_facts(scene, views, [view_facts(scene, v, shapes) for v in views])
        relations = [computed_relations(f) for f in facts]
    keys = [f"{scene.scene_id}/{v.camera.name}" for v in views]
    for i, view in enumerate(views):
        with _timed(out.seconds, "questions", out.peak_bytes):
            rng = stage_rng(recipe.hash, scene.seed, f"questions/{view.camera.name}")
            # Multi-view questions treat the previous view (cyclically) as image 1.
            other = (keys[i - 1], facts[i - 1]) if len(views) > 1 else None
            qa = questions_for_view(facts[i], recipe["questions"], rng, keys[i], other)
        out.records.append(Record(key=keys[i], scene=described[i], rgb=view.rgb, depth_m=view.depth_m,
                                  seg=view.seg, K=view.K, T_world_cam=view.T_world_cam,
                                  relations=relations[i], qa=qa))
    return out


def stored_facts(scene: Scene, views: list[View], seen: list[ViewFacts]) -> tuple[list[dict], list[ViewFacts]]:
    """Each view's scene description, and its facts as read back from that description: questions
    see the facts as stored, so re-executing a program on the record gives the same answer."""
    described = [scene_dict(scene, i, v, f) for i, (v, f) in enumerate(zip(views, seen))]
    return described, [facts_from_record(d, v.seg, v.depth_m, v.K, v.T_world_cam, boxes=cached_boxes(f),
                                         pixels=f.cache[PIXELS_KEY]) for d, v, f in zip(described, views, seen)]


def light_dict(light: Light) -> dict:
    out = {"kind": light.kind, "dir_world": rounded(light.dir_world), "intensity": round(light.intensity, 6),
           "kelvin": round(light.kelvin, 1), "radius_m": round(light.shadow_m, 4)}
    if light.pos_world_m is not None:
        out["pos_world_m"] = rounded(light.pos_world_m)
    return out


def room_dict(room: Room) -> dict:
    """What surrounds the scene: sizes, each surface's look and mean colour, background pieces."""
    surfaces = {k: {"look": s.look, "texture": s.texture.key, "rgb": rounded(s.rgb, 4)}
                for k, s in (("floor", room.floor), ("wall", room.wall), ("top", room.top), ("furniture", room.furniture),
                             ("outdoors", room.outdoors)) if s is not None}
    props = [{"kind": p.kind, "pos_world_m": rounded(p.pos_world_m), "yaw_rad": round(p.yaw_rad, 6),
              "size_m": rounded(p.size_m)} for p in room.props]
    return {"size_m": rounded(room.size_m), "height_m": round(room.height_m, 6), "surfaces": surfaces, "props": props}


def scene_dict(scene: Scene, index: int, view: View, facts: ViewFacts) -> dict:
    """The JSON description of a scene as seen from one view."""
    cam = view.camera
    return {
        "scene_id": scene.scene_id,
        "recipe": scene.recipe_name,
        "recipe_hash": scene.recipe_hash,
        "seed": scene.seed,
        "view": cam.name,
        "view_index": index,
        "views": len(scene.cameras),
        "width": cam.width,
        "height": cam.height,
        "camera": {"pos_world_m": rounded(cam.pos_world_m), "quat_wxyz": rounded(cam.quat_wxyz),
                   "fovy_deg": round(cam.fovy_deg, 6)},
        "table": {"size_m": rounded(scene.table.size_m), "top_z_m": scene.table.top_z_m,
                  "levels_m": rounded(scene.table.levels_m), "rgba": rounded(scene.table.rgba, 4),
                  "texture": scene.table.texture, "surface": scene.table.surface},
        "light": {"dir_world": rounded(scene.light.dir_world), "intensity": round(scene.light.intensity, 6)},
        "lights": [light_dict(light) for light in scene.lights],
        "room": room_dict(scene.room),
        "contacts": [list(p) for p in scene.contacts],
        "objects": [object_record(o, facts.objects[o.object_id]) for o in scene.objects],
    }
