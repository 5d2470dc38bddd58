"""Which way a thing faces, seen from the camera: named sides, and "in front of" things with a
front of their own (``oriented.yaml``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from ..vector import angle_deg, length
from .facts import ObjectFacts, ViewFacts
from .placement import MIN_FRONT_TILT

_DATA = yaml.safe_load((Path(__file__).with_name("oriented.yaml")).read_text(encoding="utf-8"))
ORIENTED = frozenset(_DATA["categories"])
FACING_DEG = float(_DATA["facing_deg"])


def front_to_camera_deg(view: ViewFacts, o: ObjectFacts) -> float | None:
    """Angle in degrees between the object's ground-projected front and the ground-projected
    direction from the object to the camera; None where the front points mostly up or down."""
    if o.front_world is None:
        return None
    front = np.asarray(o.front_world[:2], dtype=float)
    to_camera = np.asarray(view.T_world_cam[:2, 3], dtype=float) - o.center_world_m[:2]
    if length(front) < MIN_FRONT_TILT or length(to_camera) < 1e-6:
        return None
    cosine = front @ to_camera / (length(front) * length(to_camera))
    return angle_deg(cosine)


def front_reads_two_ways(view: ViewFacts, o: ObjectFacts) -> bool:
    """A thing with a front of its own that does not face the camera: "in front of" it means one
    place by the viewer and another by the thing."""
    if o.category not in ORIENTED:
        return False
    angle = front_to_camera_deg(view, o)
    return angle is None or angle > FACING_DEG
