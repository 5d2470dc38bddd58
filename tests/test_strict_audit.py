"""The independent strict-reading audit: it finds what a person would dispute, and finds nothing
in data the generator writes now."""

from __future__ import annotations

import numpy as np

from refspatial.strict_audit import STRICT, View, _audit_qa, _strict_no, asked, audit

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
    qa = {"qa_id": "t#0", "prompt": "p", "steps": qa_steps, "family": "spatial", "kind": "point"}
    rgb = np.zeros((40, 60, 3), np.uint8)
    K = np.array([[50.0, 0.0, 30.0], [0.0, 50.0, 20.0], [0.0, 0.0, 1.0]])
    return {"scene": {"objects": objects}, "T_world_cam": T, "K": K, "depth_m": depth, "seg": seg, "rgb": rgb,
            "qa": [qa]}


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


def test_bigger_needs_to_look_bigger_too():
    """A bigger cake far back looks smaller than a small cake near the camera: disputed."""
    back, front = _obj(0, 0.1, 0.8, 0.18, 0.08), _obj(1, -0.1, -0.5, 0.15, 0.08)
    assert _violations(_sample([back, front], _relate("bigger_than", [0], 1))) == [("bigger_than", 0, 1)]
    near = _obj(1, -0.1, 0.8, 0.15, 0.08)  # the same cakes side by side: no dispute
    assert _violations(_sample([back, near], _relate("bigger_than", [0], 1))) == []


def test_closer_must_not_span_the_other_in_depth():
    """A big chair whose footprint runs from before a small pot to beyond it is not nearer than it,
    though its centre is: disputed (annotator)."""
    chair, pot = _obj(0, -0.3, 0.3, 0.6, 0.9), _obj(1, 0.3, 0.4, 0.1, 0.2)
    assert _violations(_sample([chair, pot], _relate("closer_to_camera", [0], 1))) == [("closer_to_camera", 0, 1)]
    ahead = _obj(0, -0.3, 0.0, 0.3, 0.9)  # wholly in front of the pot
    assert _violations(_sample([ahead, pot], _relate("closer_to_camera", [0], 1))) == []


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


def _problems(sample: dict) -> list[str]:
    return [problem for _, problem in _audit_qa(View(sample), sample["qa"][0]) if problem]


def test_a_free_spot_hard_by_an_object_in_the_picture_is_disputed():
    """In a 600 px wide picture a spot keeps 12 px (2 %) clear of every object, less a pixel for
    the stored rounding; the platform under the spot (here the object 1 it lies on) aside."""
    sample = _sample([_obj(0, 0.0, 0.0, 0.1, 0.1), _obj(1, 0.0, 0.0, 0.4, 0.02)], [])
    sample["seg"] = np.full((400, 600), -1, np.int32)
    sample["seg"][250:400, :] = 1  # a tray the spots lie on
    sample["seg"][150:300, 50:150] = 0  # a box standing on it
    sample["qa"][0].update(family="placement", answer_points=[[175.5 / 600, 280.5 / 400]])
    assert _problems(sample) == []
    sample["qa"][0]["answer_points"] = [[155.5 / 600, 280.5 / 400], [400 / 600, 300 / 400]]
    assert len(_problems(sample)) == 1


def test_a_colour_word_must_match_the_pixels():
    """A "white" object whose pixels render dark gray is not white to a reader; a light one is."""
    sample = _sample([_obj(0, 0.0, 0.0, 0.1, 0.1)], [{"op": "filter", "color": "white", "result": [0]}])
    sample["rgb"][sample["seg"] == 0] = (60, 60, 62)
    assert _problems(sample) == ["object 0 does not look white"]
    sample["rgb"][sample["seg"] == 0] = (140, 135, 122)
    assert _problems(sample) == []


def test_between_needs_the_plan_and_the_picture():
    """Anchors 40 cm apart along x; a subject on the line between them passes, one 15 cm off it
    (more than a quarter of their distance) does not."""
    steps = [{"op": "unique", "result": 1}, {"op": "unique", "result": 2},
             {"op": "relate", "predicate": "between", "inputs": [99, 0, 1], "result": [0]}]
    for y, problems in ((0.0, []), (0.15, ["between(0, 1, 2)"])):
        objs = [_obj(0, 0.0, y, 0.05, 0.05), _obj(1, -0.2, 0.0, 0.1, 0.1), _obj(2, 0.2, 0.0, 0.1, 0.1)]
        sample = _sample(objs, steps)
        sample["seg"][:] = -1  # in the picture: left anchor, subject, right anchor along a row
        for oid, col in ((1, 5), (0, 28), (2, 50)):
            sample["seg"][18:22, col:col + 4] = oid
        assert _problems(sample) == problems


def test_the_generators_own_data_has_no_violation(tiny_dataset):
    checked, violations = audit(tiny_dataset)
    assert sum(checked.values()) > 0
    assert violations == []


def test_shown_lower_needs_the_whole_mask_lower():
    """A mug whose rows lie inside a stool's is neither lower nor higher in the picture."""
    objs = [_obj(0, 0.0, 0.0, 0.1, 0.1), _obj(1, 0.3, 0.0, 0.3, 0.45)]
    sample = _sample(objs, _relate("lower_in_image", [0], 1))
    sample["seg"][:] = -1
    sample["seg"][10:14, 5:10] = 0  # the mug, rows 10-13
    sample["seg"][2:30, 30:40] = 1  # the stool, rows 2-29
    assert _violations(sample) == [("lower_in_image", 0, 1)]
    sample["seg"][sample["seg"] == 1] = -1
    sample["seg"][2:8, 30:40] = 1  # a stool wholly above the mug in the picture
    assert _violations(sample) == []
