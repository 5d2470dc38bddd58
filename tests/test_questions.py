import numpy as np
import pytest

from refspatial.questions.generate import format_points, questions_for_view
from refspatial.questions.phrases import Phrasebook
from refspatial.questions.program import ProgramError, count_steps, execute, is_degenerate
from refspatial.questions.refer import Ordinal, Ref, Relation, anchored_refs, compile_ref, resolves, simple_refs

from helpers import obj, view

MUGS = view(
    obj(0, "mug", "red", -0.3, 0.0),
    obj(1, "mug", "red", 0.0, 0.03),
    obj(2, "mug", "blue", 0.3, 0.0),
    obj(3, "bowl", "green", 0.15, 0.35),
    obj(4, "plate", "white", -0.15, 0.35),
)


def run(ref: Ref):
    program = []
    compile_ref(ref, program)
    return program, execute(program, MUGS)


def test_filter_and_ordinal_pick_one_object():
    _, values = run(Ref(0, "mug", "mug", "red", Ordinal("left_right", "left", 1)))
    assert values[-1] == 0
    _, values = run(Ref(1, "mug", "mug", None, Ordinal("left_right", "left", 2)))
    assert values[-1] == 1
    _, values = run(Ref(2, "mug", "mug", "blue"))
    assert values[-1] == 2


def test_ambiguous_descriptions_fail():
    with pytest.raises(ProgramError, match="matches 3"):
        run(Ref(0, "mug", "mug"))


def test_ordinal_near_tie_fails():
    v = view(obj(0, "cup", "red", 0.0, 0.0), obj(1, "cup", "red", 0.01, 0.3), obj(2, "cup", "red", 0.4, 0.0))
    program = []
    compile_ref(Ref(0, "cup", "cup", None, Ordinal("left_right", "left", 1)), program)
    with pytest.raises(ProgramError, match="near-tie"):
        execute(program, v)


def test_relation_and_step_count():
    bowl = Ref(3, "bowl", "bowl")
    ref = Ref(1, "mug", "mug", "red", relations=(Relation("right_of", (Ref(0, "mug", "mug", "red", Ordinal("left_right", "left", 1)),)),))
    program, values = run(ref)
    assert values[-1] == 1 and count_steps(program) == 2
    between = Ref(1, "mug", "mug", relations=(Relation("between", (Ref(0, "mug", "mug", "red", Ordinal("left_right", "left", 1)), Ref(2, "mug", "mug", "blue"))),))
    program, values = run(between)
    assert values[-1] == 1 and count_steps(program) == 3
    two = Ref(1, "mug", "mug", relations=(Relation("right_of", (Ref(4, "plate", "plate"),)), Relation("left_of", (bowl,))))
    program, values = run(two)
    assert values[-1] == 1 and count_steps(program) == 4


def test_degenerate_relation_is_detected():
    # "the blue mug left of the bowl": the colour alone already picks it.
    ref = Ref(2, "mug", "mug", "blue", relations=(Relation("right_of", (Ref(4, "plate", "plate"),)),))
    program = []
    compile_ref(ref, program)
    assert execute(program, MUGS)[-1] == 2
    assert is_degenerate(program, MUGS)
    assert not resolves(ref, MUGS)


def test_marginal_lookalike_blocks_descriptions():
    v = view(obj(0, "mug", "red", -0.3, 0.0), obj(1, "mug", "red", 0.3, 0.0, status="marginal"), obj(2, "bowl", "red", 0, 0.3))
    assert simple_refs(v, v.objects[0]) == []
    assert simple_refs(v, v.objects[2])  # other categories are still fine


def test_every_generated_reference_resolves_to_its_target():
    rng = np.random.default_rng(0)
    for target in MUGS.askable():
        for ref in simple_refs(MUGS, target):
            assert resolves(ref, MUGS) and ref.object_id == target.object_id
        for steps in (2, 3, 4, 5):
            for ref in anchored_refs(MUGS, target, steps, rng):
                assert ref.steps == steps
                program = []
                compile_ref(ref, program)
                assert execute(program, MUGS)[-1] == target.object_id
                assert count_steps(program) == steps


def test_phrasebook_words():
    rng = np.random.default_rng(1)
    book = Phrasebook.get()
    text, texts = book.describe(Ref(1, "mug", "mug", None, Ordinal("left_right", "left", 2)), rng)
    assert text == "the second mug from the left"
    assert book.point_suffix.startswith("Your answer should be formatted as a list of tuples, i.e. [(x1, y1)]")
    assert book.point_suffix.endswith("indicating the normalized pixel locations of the points in the image.")
    assert format_points([[0.1, 0.25]]) == "[(0.100, 0.250)]"


def test_roborefer_suffix_is_byte_exact():
    expected = ("Your answer should be formatted as a list of tuples, i.e. [(x1, y1)], where each tuple contains "
                "the x and y coordinates of a point satisfying the conditions above. The coordinates should be "
                "between 0 and 1, indicating the normalized pixel locations of the points in the image.")
    assert Phrasebook.get().point_suffix == expected


def test_questions_for_view_with_masks():
    v = view(obj(0, "mug", "red", -0.3, 0.0), obj(1, "mug", "red", 0.3, 0.0), obj(2, "bowl", "blue", 0, 0.3))
    v.seg[10:20, 5:15] = 0
    v.seg[10:20, 60:70] = 1
    v.seg[30:40, 30:40] = 2
    spec = {"per_view": 8, "attempts_per_question": 10, "answer_points": 2,
            "families": {"location": 1, "choice": 1}, "steps": {1: 1, 2: 1}}
    qa = questions_for_view(v, spec, np.random.default_rng(3), "k")
    assert len(qa) >= 5 and len({q["question"] for q in qa}) == len(qa)
    for q in qa:
        values = execute([{k: n[k] for k in n if k != "result"} for n in q["steps"]], v)
        assert values == [n["result"] for n in q["steps"]]
        if q["kind"] == "point":
            assert q["question"].endswith(Phrasebook.get().point_suffix)
            for x, y in q["answer_points"]:
                assert v.seg[int(y * 60), int(x * 80)] == q["target_id"]
        else:
            assert q["answer"] in ("(A)", "(B)")
