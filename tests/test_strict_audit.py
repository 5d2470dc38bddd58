"""The independent strict-reading audit: it finds what a person would dispute, and finds nothing
in data the generator writes now."""

from __future__ import annotations

import numpy as np

from refspatial.strict_audit import STRICT, View, _strict_no, asked, audit

# An OpenCV camera looking along world +y from 1 m back: image right is world +x.
R_CAM = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])


def _obj(i: int, x: float, y: float, size: float, height: float, support=None, volume=None) -> dict:
    return {"id": i, "support": support, "volume_m3": volume if volume is not None else size * size * height,
            "box_world": {"center_m": [x, y, height / 2], "size_m": [size, size, height], "quat_wxyz": [1, 0, 0, 0]}}


def _sample(objects: list[dict], qa_steps: list[dict]) -> dict:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R_CAM, (0.0, -1.0, 0.3)
    seg = np.full((40, 60), -1, np.int32)
    depth = np.full((40, 60), 2.0, np.float32)
    for k, o in enumerate(objects):  # a patch per object, at its distance from the camera
        seg[5:15, 5 + 15 * k: 15 + 15 * k] = o["id"]
        depth[5:15, 5 + 15 * k: 15 + 15 * k] = o["box_world"]["center_m"][1] + 1.0
    qa = {"qa_id": "t#0", "prompt": "p", "steps": qa_steps}
    return {"scene": {"objects": objects}, "T_world_cam": T, "depth_m": depth, "seg": seg, "qa": [qa]}


def _relate(predicate: str, kept: list[int], anchor: int) -> list[dict]:
    return [{"op": "unique", "result": anchor}, {"op": "relate", "inputs": [99, 0], "predicate": predicate,
                                                 "reverse": False, "result": kept}]


def _violations(sample: dict) -> list:
    view = View(sample)
    out = []
    for p, a, b, said in asked(sample["qa"][0]):
        if STRICT[p](view, view.boxes[a], view.boxes[b]) != said:
            out.append((p, a, b))
    return out


def test_overlapping_extents_fail_a_strict_left_of():
    """Centres 5 cm apart, boxes 10 cm wide: "left of" by centres, overlapping to the eye."""
    objs = [_obj(0, 0.0, 0.0, 0.1, 0.1), _obj(1, 0.05, 0.2, 0.1, 0.1)]
    assert _violations(_sample(objs, _relate("left_of", [0], 1))) == [("left_of", 0, 1)]
    apart = [_obj(0, -0.2, 0.0, 0.1, 0.1), _obj(1, 0.05, 0.2, 0.1, 0.1)]
    assert _violations(_sample(apart, _relate("left_of", [0], 1))) == []


def test_a_duck_on_a_cabinet_is_neither_left_nor_right_of_it():
    objs = [_obj(0, 0.0, 0.0, 0.6, 0.8), _obj(1, 0.35, 0.0, 0.1, 0.1, support=0)]
    assert _violations(_sample(objs, _relate("left_of", [0], 1))) == [("left_of", 0, 1)]


def test_bigger_needs_both_volumes():
    """A plate (wide box, little material) against an apple: the two readings disagree."""
    plate, apple = _obj(0, -0.2, 0.0, 0.22, 0.02, volume=1.5e-4), _obj(1, 0.2, 0.0, 0.07, 0.07, volume=1.8e-4)
    assert _violations(_sample([plate, apple], _relate("bigger_than", [1], 0))) == [("bigger_than", 1, 0)]


def test_a_no_must_hold_strictly_too():
    """"Is A left of B? No" with overlapping boxes is disputed: A is not clearly right of B either."""
    objs = [_obj(0, 0.0, 0.0, 0.1, 0.1), _obj(1, 0.05, 0.2, 0.1, 0.1)]
    steps = [{"op": "unique", "result": 0}, {"op": "unique", "result": 1},
             {"op": "query", "predicate": "left_of", "inputs": [0, 1], "result": False}]
    sample = _sample(objs, steps)
    [(p, a, b, said)] = asked(sample["qa"][0])
    view = View(sample)
    assert (p, a, b, said) == ("left_of", 0, 1, False)
    assert not _strict_no(p, view, view.boxes[a], view.boxes[b])
    clear = View(_sample([_obj(0, 0.3, 0.0, 0.1, 0.1), _obj(1, 0.0, 0.2, 0.1, 0.1)], steps))
    assert _strict_no(p, clear, clear.boxes[0], clear.boxes[1])  # A wholly right of B: a fair "no"


def test_the_generators_own_data_has_no_violation(tiny_dataset):
    checked, violations = audit(tiny_dataset)
    assert sum(checked.values()) > 0
    assert violations == []
