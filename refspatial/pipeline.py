"""One scene, end to end: compose -> settle -> frame -> render -> relations -> questions.

``generate_scene`` is a pure function of (recipe, catalogue, seed) apart from the
GL rendering inside; it returns records ready for a shard, or the reason the
scene was rejected, plus the time spent in each stage (for ``make bench``).
"""

from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Iterator

import numpy as np

from .assets import Catalogue
from .camera import frame_cameras
from .compose import SceneRejected, compose
from .physics import settle
from .questions import questions_for_view
from .recipe import Recipe
from .records import Record
from .relations import ObjectFacts, ViewFacts, computed_relations, view_facts
from .render import View, render_views
from .scene import PlacedObject, Scene, quat_to_matrix
from .seeding import stage_rng

STAGES = ("compose", "physics", "camera", "render", "relations", "questions")


@dataclass
class SceneOutcome:
    seed: int
    records: list[Record] = field(default_factory=list)
    rejected: str | None = None  # reason slug
    detail: str = ""
    seconds: dict[str, float] = field(default_factory=dict)


@contextmanager
def _timed(seconds: dict[str, float], stage: str) -> Iterator[None]:
    start = time.perf_counter()
    try:
        yield
    finally:
        seconds[stage] = seconds.get(stage, 0.0) + time.perf_counter() - start


def build_scene(recipe: Recipe, catalogue: Catalogue, seed: int, seconds: dict[str, float] | None = None) -> Scene:
    """The composed, settled scene with its cameras framed (raises SceneRejected)."""
    seconds = {} if seconds is None else seconds
    with _timed(seconds, "compose"):
        scene = compose(recipe, catalogue, seed)
    with _timed(seconds, "physics"):
        scene = settle(scene, catalogue.materials, recipe)
    with _timed(seconds, "camera"):
        scene = frame_cameras(scene, recipe)
    return scene


def generate_scene(recipe: Recipe, catalogue: Catalogue, seed: int) -> SceneOutcome:
    out = SceneOutcome(seed)
    try:
        scene = build_scene(recipe, catalogue, seed, out.seconds)
    except SceneRejected as exc:
        out.rejected, out.detail = exc.reason, str(exc)
        return out
    with _timed(out.seconds, "render"):
        views = render_views(scene, catalogue.materials)
    for index, view in enumerate(views):
        out.records.append(_record(recipe, scene, index, view, out.seconds))
    return out


def _record(recipe: Recipe, scene: Scene, index: int, view: View, seconds: dict[str, float]) -> Record:
    key = f"{scene.scene_id}/{view.camera.name}"
    with _timed(seconds, "relations"):
        facts = view_facts(scene, view)
        relations = computed_relations(facts)
    with _timed(seconds, "questions"):
        rng = stage_rng(recipe.hash, scene.seed, f"questions/{view.camera.name}")
        qa = questions_for_view(facts, recipe["questions"], rng, key)
    return Record(
        key=key,
        scene=scene_dict(scene, index, view, facts),
        rgb=view.rgb,
        depth_m=view.depth_m,
        seg=view.seg,
        K=view.K,
        T_world_cam=view.T_world_cam,
        relations=relations,
        qa=qa,
    )


def _round(values, digits: int = 6) -> list[float]:
    return [round(float(v), digits) for v in np.asarray(values).ravel()]


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
        "camera": {"pos_world_m": _round(cam.pos_world_m), "quat_wxyz": _round(cam.quat_wxyz),
                   "fovy_deg": round(cam.fovy_deg, 6)},
        "table": {"size_m": _round(scene.table.size_m), "top_z_m": scene.table.top_z_m,
                  "rgba": _round(scene.table.rgba, 4), "texture": scene.table.texture},
        "light": {"dir_world": _round(scene.light.dir_world), "intensity": round(scene.light.intensity, 6)},
        "objects": [_object_dict(o, facts.objects[o.object_id]) for o in scene.objects],
    }


def _object_dict(obj: PlacedObject, facts: ObjectFacts) -> dict:
    a = obj.asset
    R = quat_to_matrix(obj.pose.quat_wxyz)
    lo, hi = a.visual.bounds_m
    centre_local = (lo + hi) / 2
    return {
        "id": obj.object_id,
        "category": a.category,
        "name": a.name,
        "color": a.color,
        "rgba": _round(a.rgba, 4),
        "material": a.material,
        "licence": a.licence,
        "params": {k: round(float(v), 6) for k, v in sorted(a.params.items())},
        "pose": {"pos_world_m": _round(obj.pose.pos_world_m), "quat_wxyz": _round(obj.pose.quat_wxyz)},
        "box_world": {
            "center_m": _round(R @ centre_local + obj.pose.pos_world_m),
            "size_m": _round(hi - lo),
            "quat_wxyz": _round(obj.pose.quat_wxyz),
        },
        "aabb_world_m": [_round(facts.aabb_world_m[0]), _round(facts.aabb_world_m[1])],
        "front_world": _round(R @ np.asarray(a.front_local)),
        "front_side": a.front_side,
        "visible_px": facts.visible_px,
        "visibility": facts.status,
    }
