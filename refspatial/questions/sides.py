"""Which named sides a question may use: "on the handle side of the mug" only where the image
shows which way the handle points.

The facing-side predicates (relations/placement.py) are geometric truths about an object's
semantic front; whether a person can check them in one picture depends on the feature that
marks the front. A printed label on a can is seen only while the can turns it towards the
camera; a mug's handle hides behind the mug only when it points away; a fork's tines show in
its outline from any camera that looks down. The rule per kind of feature is data
(`side_visibility` in templates.yaml): the largest angle, on the ground plane, between the
object's front and the direction from the object to the camera.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import yaml

from ..relations import ObjectFacts, ViewFacts
from ..relations.facing import front_to_camera_deg
from ..relations.placement import NO_FRONT

TEMPLATES = Path(__file__).with_name("templates.yaml")
SIDE_PREDICATES = ("on_facing_side", "on_back_side")


@lru_cache(maxsize=1)
def side_limits() -> dict[str, tuple[float, float]]:
    """Side word -> (largest front-to-camera angle in degrees, least share of the image the
    object covers) at which that side may be named; the key "" holds the default for side
    words the table does not list."""
    table = yaml.safe_load(TEMPLATES.read_text(encoding="utf-8"))["side_visibility"]

    def limit(rule: dict) -> tuple[float, float]:
        return float(rule["max_deg"]), float(rule["min_share"])

    limits = {"": limit(table[table["default"]])}
    for kind, rule in table.items():
        if kind != "default":
            limits.update({side: limit(rule) for side in rule["sides"]})
    return limits


def side_visible(view: ViewFacts, o: ObjectFacts) -> bool:
    """Whether a question may name the object's side (``o.front_side``) in this view (memoised
    per view and facts object: every description search asks it of every anchor)."""
    key = ("side_visible", o)
    if key not in view.cache:
        view.cache[key] = _side_visible(view, o)
    return view.cache[key]


def _side_visible(view: ViewFacts, o: ObjectFacts) -> bool:
    if o.front_side == NO_FRONT:
        return False
    angle = front_to_camera_deg(view, o)
    limits = side_limits()
    max_deg, min_share = limits.get(o.front_side, limits[""])
    return angle is not None and angle <= max_deg and o.visible_px >= min_share * view.seg.size
