"""The hand-checked hard cases (tests/data/human_reading.yaml): the definitions may not drift
back to readings a person disputes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from helpers import K, T, view

from refspatial.questions.program import QUANTITIES
from refspatial.relations import PREDICATES, TABLE, ObjectFacts
from refspatial.relations.geometry import project

CASES = yaml.safe_load((Path(__file__).parent / "data" / "human_reading.yaml").read_text(encoding="utf-8"))


def _facts(o: dict) -> ObjectFacts:
    (x, y, z), (sx, sy, sz) = o["at"], o["size"]
    lo, hi = np.array([x - sx / 2, y - sy / 2, z]), np.array([x + sx / 2, y + sy / 2, z + sz])
    centre = (lo + hi) / 2
    uv, depth = project(centre[None], K, T)
    pose = np.eye(4)
    pose[:3, 3] = [x, y, z]
    return ObjectFacts(
        o["id"], o["category"], o["category"].replace("_", " "), "red", np.stack([lo, hi]), float(x), float(y),
        float(o.get("depth", depth[0])), 500, "visible",
        footprint_world=np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]]),
        front_world=np.array([1.0, 0.0, 0.0]), volume_m3=float(o.get("volume", sx * sy * sz)),
        centroid_px=(float(uv[0, 0]), float(uv[0, 1])), support=o.get("support", TABLE), pose_world=pose,
    )


@pytest.mark.parametrize("case", CASES["cases"], ids=[c["name"] for c in CASES["cases"]])
def test_verdicts_a_person_agrees_with(case):
    objects = [_facts(o) for o in case["objects"]]
    v = view(*objects)
    for predicate, ids, expected in case["verdicts"]:
        got = PREDICATES[predicate](v, *(v.objects[i] for i in ids))
        assert got == expected, f"{predicate}{tuple(ids)}: {got}, a person says {expected}"


@pytest.mark.parametrize("case", CASES["measures"], ids=[c["name"] for c in CASES["measures"]])
def test_quantities_measure_what_the_words_say(case):
    v = view(*(_facts(o) for o in case["objects"]))
    for name, ids, expected in case["values"]:
        measure = QUANTITIES.get(name) or PREDICATES[name]
        assert measure(v, *(v.objects[i] for i in ids)).value == pytest.approx(expected, abs=1e-3), name
