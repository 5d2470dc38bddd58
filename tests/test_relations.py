from hypothesis import assume, given, settings
from hypothesis import strategies as st

from refspatial.relations import PREDICATES, true_relations
from refspatial.relations.directional import MIN_MARGIN_M, axis_margin, depth_margin

from helpers import obj, view

coord = st.floats(-0.5, 0.5, allow_nan=False)


@given(coord, coord, coord, coord)
@settings(max_examples=200, deadline=None)
def test_inverse_pairs_agree_and_are_antisymmetric(x1, y1, x2, y2):
    a, b = obj(0, "mug", "red", x1, y1), obj(1, "cup", "blue", x2, y2)
    v = view(a, b)
    for name, pred in PREDICATES.items():
        if pred.arity != 2:
            continue
        ab, ba = pred(v, a, b), pred(v, b, a)
        if pred.inverse:
            assert ab == PREDICATES[pred.inverse](v, b, a)
        if ab is not None:
            assert ba is not None and ba == (not ab), name  # decided both ways, opposite answers
        else:
            assert ba is None


@given(coord, coord, coord, coord, st.floats(-2, 2), st.floats(-2, 2))
@settings(max_examples=100, deadline=None)
def test_translating_everything_changes_nothing(x1, y1, x2, y2, dx, dy):
    v1 = view(obj(0, "mug", "red", x1, y1), obj(1, "cup", "blue", x2, y2), obj(2, "bowl", "red", 0.1, 0.2))
    v2 = view(obj(0, "mug", "red", x1 + dx, y1 + dy), obj(1, "cup", "blue", x2 + dx, y2 + dy),
              obj(2, "bowl", "red", 0.1 + dx, 0.2 + dy))
    # depth is camera-relative: the camera moves with the scene, so shift it back
    v2 = view(*(type(o)(**{**o.__dict__, "depth_m": o.depth_m - dy}) for o in v2.objects))
    assume(_clear_of_margins(v1))  # exactly on a margin, float rounding may tip either way
    assert true_relations(v1) == true_relations(v2)


def _clear_of_margins(v, eps=1e-6) -> bool:
    for a in v.objects:
        for b in v.objects:
            if a is b:
                continue
            gaps = [abs(a.lateral_m - b.lateral_m) - axis_margin(a, b, v.right_axis),
                    abs(a.forward_m - b.forward_m) - axis_margin(a, b, v.forward_axis),
                    abs(a.depth_m - b.depth_m) - depth_margin(a, b)]
            if any(abs(g) < eps for g in gaps):
                return False
    return True


def test_transitivity_of_left_of():
    a, b, c = obj(0, "mug", "red", -0.3, 0), obj(1, "cup", "red", 0.0, 0), obj(2, "can", "red", 0.3, 0)
    v = view(a, b, c)
    left = PREDICATES["left_of"]
    assert left(v, a, b) and left(v, b, c) and left(v, a, c)


def test_near_ties_are_undecided():
    a, b = obj(0, "mug", "red", 0.0, 0.0), obj(1, "cup", "red", 0.01, 0.005)
    v = view(a, b)
    for name in ("left_of", "right_of", "in_front_of", "behind", "closer_to_camera"):
        assert PREDICATES[name](v, a, b) is None, name
    far = obj(1, "cup", "red", MIN_MARGIN_M * 3, 0.0)
    assert PREDICATES["left_of"](view(a, far), a, far) is True


def test_known_layout():
    mug = obj(0, "mug", "red", -0.3, 0.0)
    cup = obj(1, "cup", "blue", 0.3, 0.0)
    bowl = obj(2, "bowl", "green", 0.0, 0.3)
    plate = obj(3, "plate", "white", 0.0, 0.0)
    v = view(mug, cup, bowl, plate)
    P = PREDICATES
    assert P["left_of"](v, mug, cup) and P["right_of"](v, cup, mug)
    assert P["behind"](v, bowl, plate) and P["in_front_of"](v, plate, bowl)
    assert P["closer_to_camera"](v, plate, bowl) and not P["closer_to_camera"](v, bowl, plate)
    assert P["between"](v, plate, mug, cup) is True
    assert P["between"](v, bowl, mug, cup) is False  # 30 cm off the corridor
    assert P["between"](v, mug, plate, cup) is False  # beyond an end
    assert P["left_of"](v, mug, mug) is None  # never related to itself


def test_true_relations_skip_objects_too_small_to_ask_about():
    v = view(obj(0, "mug", "red", -0.3, 0), obj(1, "cup", "red", 0.3, 0, status="marginal"))
    assert true_relations(v) == []


def test_every_predicate_documents_its_definition():
    for name, pred in PREDICATES.items():
        assert pred.fn.__doc__ and len(pred.fn.__doc__) > 40, name
        assert pred.frame in {"viewer", "world", "image", "camera", "object"}
