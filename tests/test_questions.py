"""The question engine on hand-built views: programs, descriptions, step counts and every family."""

import itertools

import numpy as np
import pytest

from refspatial.annotate import rle_decode
from refspatial.questions import FAMILIES, execute, questions_for_view
from refspatial.questions.common import format_points
from refspatial.questions.phrases import Phrasebook
from refspatial.questions.program import OPS, ProgramError, count_steps, is_degenerate
from refspatial.questions.refer import Ordinal, Ref, Relation, anchored_refs, compile_ref, resolves, simple_refs

from helpers import T, obj, view

MUGS = view(
    obj(0, "mug", "red", -0.3, 0.0),
    obj(1, "mug", "red", 0.0, 0.03),
    obj(2, "mug", "blue", 0.3, 0.0),
    obj(3, "bowl", "green", 0.15, 0.35),
    obj(4, "plate", "white", -0.15, 0.35),
)
SPEC = {"per_view": 10, "attempts_per_question": 10, "answer_points": 2,
        "families": {f: 1 for f in FAMILIES}, "steps": {1: 1, 2: 1, 3: 1, 4: 1, 5: 1}}


def run(ref: Ref, v=MUGS):
    program = []
    compile_ref(ref, program)
    return program, execute(program, v)


def strip(steps):
    return [{k: v for k, v in n.items() if k != "result"} for n in steps]


def test_point_coordinates_round_as_numpy_rounds():
    # Every pixel centre of common frame sizes, rounded in Python floats, is the number (and the
    # JSON text) numpy's round(x, 3) of the same centre gave, which records were written with.
    from refspatial.questions.common import _thousandths

    for size in (240, 256, 320, 480, 512, 540, 640, 720, 960, 1024, 1080, 1280, 1920):
        for pixel in range(size):
            want = round((np.int64(pixel) + 0.5) / size, 3)
            got = _thousandths((pixel + 0.5) / size)
            assert got == want and repr(got) == repr(float(want)), (pixel, size)


def test_filter_and_ordinal_pick_one_object():
    assert run(Ref(0, "mug", "mug", "red", Ordinal("left_right", "left", 1)))[1][-1] == 0
    assert run(Ref(1, "mug", "mug", None, Ordinal("left_right", "left", 2)))[1][-1] == 1
    assert run(Ref(2, "mug", "mug", "blue"))[1][-1] == 2


def test_ambiguous_descriptions_fail():
    with pytest.raises(ProgramError, match="matches 3"):
        run(Ref(0, "mug", "mug"))


def test_ordinal_near_tie_fails():
    v = view(obj(0, "cup", "red", 0.0, 0.0), obj(1, "cup", "red", 0.01, 0.3), obj(2, "cup", "red", 0.4, 0.0))
    with pytest.raises(ProgramError, match="near-tie"):
        run(Ref(0, "cup", "cup", None, Ordinal("left_right", "left", 1)), v)


def test_relations_and_step_counts():
    leftmost = Ref(0, "mug", "mug", "red", Ordinal("left_right", "left", 1))
    program, values = run(Ref(1, "mug", "mug", "red", relations=(Relation("right_of", (leftmost,)),)))
    assert values[-1] == 1 and count_steps(program) == 2
    between = Relation("between", (leftmost, Ref(2, "mug", "mug", "blue")))
    program, values = run(Ref(1, "mug", "mug", relations=(between,)))
    assert values[-1] == 1 and count_steps(program) == 3
    two = (Relation("right_of", (Ref(4, "plate", "plate"),)), Relation("left_of", (Ref(3, "bowl", "bowl"),)))
    program, values = run(Ref(1, "mug", "mug", relations=two))
    assert values[-1] == 1 and count_steps(program) == 4
    program, values = run(Ref(1, "mug", "mug", relations=(between, two[0])))
    assert values[-1] == 1 and count_steps(program) == 5
    assert count_steps(run(Ref(2, "mug", "mug", "blue"))[0]) == 1


def test_degenerate_relation_is_detected():
    # "the blue mug right of the plate": the colour alone already picks it.
    ref = Ref(2, "mug", "mug", "blue", relations=(Relation("right_of", (Ref(4, "plate", "plate"),)),))
    program, values = run(ref)
    assert values[-1] == 2 and is_degenerate(program, MUGS) and not resolves(ref, MUGS)
    # Given the program's values, the test reuses them and reaches the same verdict.
    assert is_degenerate(program, MUGS, values)
    fine = Ref(2, "mug", "mug", relations=(Relation("right_of", (Ref(3, "bowl", "bowl"),)),))
    program, values = run(fine)
    assert values[-1] == 2 and not is_degenerate(program, MUGS, values) and not is_degenerate(program, MUGS)


def test_small_part_searches_by_loops_match_the_array_search(monkeypatch):
    """Combination searches up to LOOPED_COMBOS run as plain loops; on random part sets (up to 70
    objects, past 64-bit masks) they must agree with the array version, combination for combination."""
    from refspatial.questions import refer

    rng = np.random.default_rng(7)
    for _ in range(1500):
        n_objects = int(rng.integers(2, 70))
        ids = sorted(int(i) for i in rng.choice(n_objects, size=int(rng.integers(1, min(n_objects, 8) + 1)),
                                                 replace=False))
        head, target = sum(1 << i for i in ids), 1 << ids[0]

        def part():
            kept = sum(1 << i for i in ids if rng.random() < 0.6) | target
            undecided = sum(1 << i for i in ids if rng.random() < 0.1) & ~kept
            return refer._Part((), 1 << int(rng.integers(n_objects)), 1 << int(rng.integers(6)), kept, undecided)

        lists = [[part() for _ in range(int(rng.integers(0, 5)))] for _ in range(int(rng.integers(1, 4)))]
        monkeypatch.setattr(refer, "LOOPED_COMBOS", -1)
        arrays = refer._fits(target, head, lists)
        monkeypatch.setattr(refer, "LOOPED_COMBOS", 10**9)
        loops = refer._fits(target, head, lists)
        assert loops.shape == arrays.shape and np.array_equal(loops, arrays)


def test_marginal_lookalike_blocks_descriptions():
    v = view(obj(0, "mug", "red", -0.3, 0.0), obj(1, "mug", "red", 0.3, 0.0, status="marginal"),
             obj(2, "bowl", "red", 0, 0.3))
    assert simple_refs(v, v.objects[0]) == []
    assert simple_refs(v, v.objects[2])


def test_unary_relation_description_counts_one_step():
    v = view(obj(0, "cup", "red", 0.0, 0.0), obj(1, "cup", "red", 0.1, 0.35), obj(2, "bowl", "red", -0.3, 0.0))
    refs = anchored_refs(v, v.objects[1], 1, np.random.default_rng(0), Phrasebook.get().phrased)
    assert refs
    for r in refs:  # one unary relation: no anchor, one phrase, one step
        assert len(r.relations) == 1 and r.relations[0].anchors == () and r.steps == 1
        assert r.relations[0].predicate in ("at_edge", "at_corner")
    program, values = run(refs[0], v)
    assert values[-1] == 1 and count_steps(program) == 1
    text, _ = Phrasebook.get().describe(refs[0], np.random.default_rng(0), v)
    assert "table" in text


def test_five_step_description_on_a_scene_made_for_it():
    # Cup 1 alone is both between the mug and the bowl and left of the plate.
    v = view(obj(0, "mug", "red", -0.3, 0.0), obj(1, "cup", "red", -0.1, 0.0), obj(2, "cup", "red", 0.1, 0.0),
             obj(3, "cup", "red", -0.3, 0.3), obj(4, "bowl", "blue", 0.3, 0.0), obj(5, "plate", "white", 0.0, 0.3))
    for seed in range(20):
        refs = anchored_refs(v, v.objects[1], 5, np.random.default_rng(seed), Phrasebook.get().phrased)
        if refs:
            program, values = run(refs[0], v)
            assert values[-1] == 1 and count_steps(program) == 5 and not is_degenerate(program, v)
            return
    raise AssertionError("no five-step description found in 20 seeds")


@pytest.mark.parametrize("steps", [2, 3, 4])
def test_generated_descriptions_resolve_with_their_step_count(steps):
    rng = np.random.default_rng(steps)
    found = 0
    for target in MUGS.askable():
        for any_category in (False, True):
            for ref in anchored_refs(MUGS, target, steps, rng, Phrasebook.get().phrased, any_category):
                program, values = run(ref)
                assert values[-1] == target.object_id and count_steps(program) == steps == ref.steps
                assert not is_degenerate(program, MUGS)
                found += 1
    assert found > 0


def _chained(ref: Ref) -> list[Ref]:
    return [a for rel in ref.relations for a in rel.anchors if a.relations]


@pytest.mark.parametrize("steps", [3, 4, 5])
def test_chained_anchors_count_their_own_steps_and_name_each_object_once(steps):
    """Long descriptions may reach the target through an anchor picked by a relation of its own
    ("the mug left of the red mug that is right of the plate"). Their step count is the program's,
    every object is named once, and the chain is the last clause, with a single relation, so no
    later phrase can be read as the anchor's."""
    # MUGS has no object alone at the table's edge, the only one-step anchor description; EDGE has one.
    edge = view(obj(0, "cup", "red", 0.0, 0.0), obj(1, "cup", "red", 0.1, 0.35), obj(2, "bowl", "red", -0.3, 0.0),
                obj(3, "plate", "white", 0.3, 0.1))
    chained = 0
    for seed, v in itertools.product(range(4), (MUGS, edge)):
        v.cache.clear()
        rng = np.random.default_rng(seed)
        for target in v.askable():
            for any_category in (False, True):
                for ref in anchored_refs(v, target, steps, rng, Phrasebook.get().phrased, any_category, wanted=8):
                    program, values = run(ref, v)
                    assert values[-1] == target.object_id and count_steps(program) == steps == ref.steps
                    assert not is_degenerate(program, v)
                    named = [a.object_id for a in dict.fromkeys(a for rel in ref.relations for a in rel.anchors)]
                    named += [b.object_id for a in _chained(ref) for rel in a.relations for b in rel.anchors]
                    assert target.object_id not in named and len(set(named)) == len(named)
                    for a in _chained(ref):
                        assert len(a.relations) == 1 and a is ref.relations[-1].anchors[-1]
                        chained += 1
    assert chained > 0


def test_two_phrases_on_one_anchor_find_it_once_and_count_three_steps():
    """Two cups left of the plate and two behind it: only "left of and behind the plate" picks the
    back-left one. The plate is one node of the program and named once in the words."""
    v = view(obj(0, "cup", "red", -0.25, 0.45), obj(1, "cup", "red", -0.25, -0.25), obj(2, "cup", "red", 0.25, 0.45),
             obj(3, "plate", "white", 0.0, 0.1, size=0.12))
    pairs = []
    for seed in range(12):
        v.cache.clear()
        for ref in anchored_refs(v, v.objects[0], 3, np.random.default_rng(seed), Phrasebook.get().phrased, wanted=8):
            if len(ref.relations) == 2 and ref.relations[0].anchors == ref.relations[1].anchors:
                pairs.append(ref)
    assert pairs, "no pair of phrases on one anchor in 12 seeds"
    for ref in pairs:
        program, values = run(ref, v)
        assert values[-1] == 0 and count_steps(program) == ref.steps == 3 and not is_degenerate(program, v)
        assert {r.predicate for r in ref.relations} == {"left_of", "behind"}
        assert sum(n["op"] == "filter" and n["category"] == "plate" for n in program) == 1
        text, _ = Phrasebook.get().describe(ref, np.random.default_rng(1), v)
        assert text.count("plate") == 1 and " and " in text and text.endswith("the plate"), text


def test_between_an_anchor_and_a_chained_anchor_is_five_steps_with_the_chain_last():
    """"The cup between the plate and the bowl behind the mug": three objects and two phrases."""
    v = view(obj(0, "cup", "red", 0.0, 0.1), obj(1, "cup", "red", 0.0, 0.45), obj(2, "plate", "white", -0.35, 0.1),
             obj(3, "bowl", "green", 0.35, 0.1), obj(4, "bowl", "green", 0.35, 0.45), obj(5, "mug", "blue", 0.35, -0.2))
    found = []
    for seed in range(12):
        v.cache.clear()
        for ref in anchored_refs(v, v.objects[0], 5, np.random.default_rng(seed), Phrasebook.get().phrased, wanted=8):
            (rel, *more) = ref.relations
            if not more and rel.predicate == "between" and rel.anchors[-1].relations:
                found.append(ref)
    assert found, "no between with a chained anchor in 12 seeds"
    for ref in found:
        program, values = run(ref, v)
        assert values[-1] == 0 and count_steps(program) == ref.steps == 5 and not is_degenerate(program, v)
        chained = ref.relations[0].anchors[-1]
        text, texts = Phrasebook.get().describe(ref, np.random.default_rng(0), v)
        assert text.endswith(texts[chained]) and len(chained.relations) == 1, text


def test_a_chained_description_reads_through_its_intermediate_object():
    mug = Ref(1, "mug", "mug", "red", relations=(Relation("right_of", (Ref(4, "plate", "plate"),)),))
    ref = Ref(0, "mug", "mug", relations=(Relation("left_of", (mug,)),))
    program, values = run(ref)
    assert values[-1] == 0 and count_steps(program) == ref.steps == 4
    text, texts = Phrasebook.get().describe(ref, np.random.default_rng(0), MUGS)
    assert texts[mug] in text and "plate" in texts[mug] and text.endswith(texts[mug])


def test_count_measure_and_mark_operations():
    program = [{"op": "scene"}, {"op": "filter", "inputs": [0], "category": "mug", "color": None},
               {"op": "count", "inputs": [1]}]
    assert execute(program, MUGS)[-1] == 3
    program = []
    a = compile_ref(Ref(2, "mug", "mug", "blue"), program)
    b = compile_ref(Ref(4, "plate", "plate"), program)
    program.append({"op": "measure", "inputs": [a, b], "quantity": "centre_distance"})
    d = np.linalg.norm(MUGS.objects[2].center_world_m - MUGS.objects[4].center_world_m)
    assert execute(program, MUGS)[-1] == pytest.approx(d, abs=1e-4)
    program[-1] = {"op": "measure", "inputs": [a, b], "quantity": "distance_between"}  # the gap: less than centres
    assert execute(program, MUGS)[-1] == pytest.approx(MUGS.footprint_gap(MUGS.objects[2], MUGS.objects[4]), abs=1e-4)
    program[-1] = {"op": "mark", "inputs": [a], "marks": [{"label": "A", "object_id": 4}, {"label": "B", "object_id": 2}]}
    assert execute(program, MUGS)[-1] == "B"


def test_camera_move_between_two_views():
    moved = T.copy()
    moved[:3, 3] += [0.3, 0, 0]  # the camera slid to its right
    views = {"other": MUGS, "self": view(*MUGS.objects, T_world_cam=moved)}
    assert execute([{"op": "camera_move", "motion": "shift"}], views)[-1] == "right"
    with pytest.raises(ProgramError):
        execute([{"op": "camera_move", "motion": "turn"}], views)  # no turn at all


def test_a_turn_is_asked_only_when_the_camera_did_not_circle():
    """Circling the table, the camera moves left while it turns right: no turn a person can name."""
    from refspatial.camera import look_rotation

    def camera(yaw_deg: float, x: float):
        pose = T.copy()
        pose[:3, :3] = look_rotation(np.radians(yaw_deg), -np.radians(30)) @ np.diag([1.0, -1.0, -1.0])
        pose[:3, 3] += [x, 0.0, 0.0]
        return view(*MUGS.objects, T_world_cam=pose)

    def turn(second):
        return execute([{"op": "camera_move", "motion": "turn"}], {"other": MUGS, "self": second})[-1]

    assert turn(camera(60, 0.0)) == "right"  # heading 90 -> 60 degrees, standing still: a pan
    assert turn(camera(60, 0.3)) == "right"  # and slid right too: the picture moves one way
    with pytest.raises(ProgramError, match="circled"):
        turn(camera(60, -0.3))  # slid left while turning right: round the table
    assert execute([{"op": "camera_move", "motion": "shift"}], {"other": MUGS, "self": camera(60, -0.3)})[-1] == "left"


def test_phrasebook_has_three_phrasings_per_template_and_the_exact_suffix():
    data = Phrasebook.get().data
    for family in ("location", "placement", "identify_name", "identify_point", "yes_no", "yes_no_unary", "pick",
                   "multiview_point", "visual_choice"):
        assert len(data[family]) >= 3, family
    for kind, options in {**data["quantity"], **data["camera_move"]}.items():
        assert len(options) >= 3, kind
    expected = ("Your answer should be formatted as a list of tuples, i.e. [(x1, y1)], where each tuple contains "
                "the x and y coordinates of a point satisfying the conditions above. The coordinates should be "
                "between 0 and 1, indicating the normalized pixel locations of the points in the image.")
    assert Phrasebook.get().point_suffix == expected
    assert format_points([[0.1, 0.25]]) == "[(0.100, 0.250)]"


def test_every_op_documents_itself():
    for name, fn in OPS.items():
        assert fn.__doc__, name


def test_families_on_a_hand_built_view():
    other = view(*MUGS.objects)
    qa = []
    for seed in range(3):
        batch = questions_for_view(MUGS, {**SPEC, "per_view": 40}, np.random.default_rng(seed), "k", ("k0", other))
        assert len({q["question"] for q in batch}) == len(batch)
        qa += batch
    families = {q["family"] for q in qa}
    assert {"location", "identify", "choice", "quantitative", "visual_choice", "multiview", "placement"} <= families
    for q in qa:
        views = {"self": MUGS, "other": other}
        assert execute(strip(q["steps"]), views) == [n["result"] for n in q["steps"]]
        if q["kind"] == "point":
            assert q["question"].endswith(Phrasebook.get().point_suffix)
            answer_view = MUGS
            on = rle_decode(q["free_mask"]) if q["family"] == "placement" else answer_view.seg == q["target_id"]
            for x, y in q["answer_points"]:
                assert on[int(y * MUGS.height), int(x * MUGS.width)]
            assert q["reasoning"].startswith("<think>[Position]")
        if q["kind"] in ("yes_no", "pick", "box"):
            assert q["answer"].startswith("(")
        if q["family"] == "multiview":
            assert q["images"] == ["k0", "k"]


def test_no_object_is_asked_for_twice_by_the_same_relations():
    """Pointing at, naming or boxing one object by the same relations to the same anchors (and the
    same ordinals) is one question however it is worded; a view asks it once (annotator read 41:
    "the basket" and "the brown basket" with one basket seen)."""
    other = view(*MUGS.objects)
    for seed in range(4):
        asked = set()
        for q in questions_for_view(MUGS, {**SPEC, "per_view": 40}, np.random.default_rng(seed), "k", ("k0", other)):
            if q["family"] not in ("location", "identify", "visual_choice"):
                continue
            steps = q["steps"]
            relations = sorted((n["predicate"], bool(n.get("reverse")), [steps[i]["result"] for i in n["inputs"][1:]])
                               for n in steps if n["op"] == "relate")
            ordinals = sorted((n["axis"], n["end"], n["rank"]) for n in steps if n["op"] == "ordinal")
            key = repr((q["target_id"], relations, ordinals))
            assert key not in asked, (seed, q["question"])
            asked.add(key)


@pytest.mark.parametrize("steps", [1, 2, 3, 4, 5])
def test_a_description_s_key_is_its_program_s(steps):
    """The key the search passes asked descriptions over by (read from the description) is the
    one the driver reads from the question's stored steps."""
    from refspatial.questions.program import with_results
    from refspatial.questions.refer import object_key, ref_key

    rng = np.random.default_rng(steps)
    keys = 0
    for target in MUGS.objects:
        refs = anchored_refs(MUGS, target, steps, rng, Phrasebook.get().phrased, wanted=4)
        refs += anchored_refs(MUGS, target, steps, rng, Phrasebook.get().phrased, any_category=True, wanted=4)
        refs += simple_refs(MUGS, target) if steps == 1 else []
        for ref in refs:
            program: list = []
            compile_ref(ref, program)
            nodes = with_results(program, execute(program, MUGS))
            relations = [(n["predicate"], bool(n.get("reverse")), tuple(nodes[i]["result"] for i in n["inputs"][1:]))
                         for n in nodes if n["op"] == "relate"]
            ordinals = [(n["axis"], n["end"], n["rank"]) for n in nodes if n["op"] == "ordinal"]
            assert ref_key(ref) == object_key(nodes[-1]["result"], relations, ordinals), ref
            keys += 1
    assert keys > 0


def test_placement_shapes_add_up_to_their_step_count():
    from refspatial.questions.placement import ANCHORS, SHAPES

    for steps, shapes in SHAPES.items():
        for kinds, anchor_steps in shapes:
            assert sum(ANCHORS[k] for k in kinds) == len(anchor_steps)
            assert sum(anchor_steps) + sum(k != "on_top" for k in kinds) == steps, (kinds, anchor_steps)


def test_placement_around_a_chained_anchor():
    """"A free spot in front of the mug that is by the front of the second mug": the anchor is found
    by a relation of its own, the step count says so, and the answer lies in the free region."""
    from refspatial.questions.placement import placement

    found = 0
    for seed in range(60):  # most draws pick anchors that leave no free room, or the plain two-sector shape
        MUGS.cache.clear()
        qa = placement({"self": MUGS}, SPEC, 4, np.random.default_rng(seed))
        if qa is None or not any(n["op"] == "relate" for n in qa["steps"]):
            continue
        found += 1
        assert qa["num_steps"] == 4 and execute(strip(qa["steps"]), MUGS) == [n["result"] for n in qa["steps"]]
        free = rle_decode(qa["free_mask"])
        for x, y in qa["answer_points"]:
            assert free[int(y * MUGS.height), int(x * MUGS.width)]
        anchor = qa["steps"][qa["steps"][-1]["inputs"][0]]
        inner = qa["steps"][next(n for n in qa["steps"] if n["op"] == "relate")["inputs"][1]]
        traced = [r["text"] for r in qa["reasoning_steps"]]
        assert anchor["text"] in qa["question"] and traced.index(inner["text"]) < traced.index(anchor["text"])
        assert traced[-1] == qa["ref"]
    assert found >= 2


def test_mask_points_come_from_the_whole_frames_erosion():
    """Answer points are drawn from the eroded mask, eroded only inside the mask's padded box.
    Every point must be a pixel the whole frame's erosion keeps and round back onto the mask,
    also for masks that touch the frame's edge."""
    import cv2

    from refspatial.questions.common import sample_mask_points

    rng = np.random.default_rng(11)
    h, w = 54, 96
    for _ in range(40):
        mask = np.zeros((h, w), dtype=bool)
        for _ in range(int(rng.integers(1, 4))):
            (r0, c0), (dr, dc) = rng.integers(-10, [h, w]), rng.integers(3, 30, 2)
            mask[max(r0, 0):r0 + dr, max(c0, 0):c0 + dc] = True
        eroded = cv2.erode(mask.view(np.uint8), np.ones((3, 3), np.uint8), iterations=2).astype(bool)
        points = sample_mask_points(mask, 30, np.random.default_rng(0), erode=2)
        if not eroded.any():
            assert points is None
            continue
        assert points is not None and len(points) == 30
        for x, y in points:
            assert mask[int(y * h), int(x * w)]
            assert eroded[round(y * h - 0.5), round(x * w - 0.5)]  # a pixel centre, to 3 decimals


def test_no_yes_no_question_asks_whether_a_big_thing_is_inside_a_small_container():
    """"Is the stool inside the jar?" is trivially no: only things smaller than the container are asked."""
    from refspatial.questions.choice import _yes_no
    from refspatial.scene import Cavity

    jar = obj(0, "jar", "green", 0.2, 0.1, size=0.08, height=0.12, cavity=Cavity("cylinder", (0.035, 0.035), 0.01, 0.12))
    stool = obj(1, "stool", "black", -0.25, 0.1, size=0.35, height=0.45)
    lemon = obj(2, "lemon", "yellow", -0.2, 0.45, size=0.05, height=0.05)
    v = view(jar, stool, lemon)
    asked = []
    for seed in range(40):
        qa = _yes_no({"self": v}, ["inside"], np.random.default_rng(seed))
        if qa is not None:
            node = qa["steps"][-1]
            asked.append(tuple(qa["steps"][k]["result"] for k in node["inputs"]))
    assert asked and all(subject != 1 for subject, _ in asked), asked


def test_a_relation_true_of_nearly_everything_must_rule_out_more_than_its_anchor():
    """With two cutting boards, "the cutting board not touching the yellow cutting board" only says
    "the other one"; "left of the yellow cutting board" says where it is (annotators)."""
    v = view(obj(0, "cutting_board", "red", -0.25, 0.1, size=0.2, height=0.02),
             obj(1, "cutting_board", "yellow", 0.25, 0.1, size=0.2, height=0.02),
             obj(2, "mug", "blue", 0.0, 0.45))
    predicates = set()
    for seed in range(10):
        v.cache.clear()
        for ref in anchored_refs(v, v.objects[0], 2, np.random.default_rng(seed), Phrasebook.get().phrased, wanted=8):
            predicates |= {r.predicate for r in ref.relations if r.anchors[0].object_id == 1}
    assert "left_of" in predicates and not predicates & {"separated", "far"}, predicates


def test_a_weighted_draw_is_numpys_cumulative_search():
    # weighted_index sums and bisects in Python; it must pick what numpy's cumsum and
    # searchsorted pick from the same uniform draw (records depend on every pick), and take one
    # draw from the generator, as before.
    from refspatial.questions.balance import weighted_index

    rng = np.random.default_rng(3)
    for _ in range(20_000):
        weights = [float(w) for w in rng.uniform(0.01, 5.0, rng.integers(1, 12))]
        if rng.random() < 0.2:
            weights = [float(w) for w in rng.integers(1, 4, len(weights))]  # ties in the sums
        state = rng.bit_generator.state
        got = weighted_index(rng, weights)
        after = rng.bit_generator.state
        rng.bit_generator.state = state
        cumulative = np.cumsum(weights)
        assert got == int(np.searchsorted(cumulative, rng.random() * cumulative[-1], side="right"))
        assert rng.bit_generator.state == after


def test_memoised_fitting_rows_ask_the_same_questions(monkeypatch):
    """The description search keeps each shape's fitting rows per view; worked out afresh at every
    search instead, every question of every family comes out the same."""
    from refspatial.questions import refer

    def asked(seed):
        other = view(*MUGS.objects)
        return questions_for_view(view(*MUGS.objects), {**SPEC, "per_view": 40}, np.random.default_rng(seed), "k",
                                  ("k0", other))

    memoised = [asked(seed) for seed in range(3)]
    calls = []

    def afresh(target, head, shape, lists, memo):
        calls.append((target, head, shape))
        return np.argwhere(refer._fits(1 << target, head, lists))

    monkeypatch.setattr(refer, "_fitting_rows", afresh)
    assert [asked(seed) for seed in range(3)] == memoised
    assert len(calls) > len(set(calls))  # searches did repeat, so the memo was used above


def test_list_shuffles_draw_as_numpys_permutation():
    """Description search shuffles a description's shapes in place where it used
    ``rng.permutation``: the same order from the same draws, the generator left in the same state
    (else every question after would change)."""
    for n in range(0, 100):
        for seed in range(5):
            a, b = np.random.default_rng(seed), np.random.default_rng(seed)
            items = [("shape", k) for k in range(n)]
            expected = [items[k] for k in a.permutation(n).tolist()]
            shuffled = list(items)
            b.shuffle(shuffled)
            assert shuffled == expected
            assert a.random() == b.random()


def test_target_order_sorts_its_keys_as_numpy_s_stable_argsort():
    from refspatial.questions.common import _target_exponents, descending, target_order

    rng = np.random.default_rng(5)
    for n in range(1, 12):
        for _ in range(200):  # few distinct values: most draws hold ties, and 0.0 beside -0.0
            keys = rng.integers(-2, 3, n).astype(float) * rng.choice([1.0, 0.5], n)
            keys[keys == 0] *= rng.choice([1.0, -1.0], int((keys == 0).sum()))
            assert descending(keys.tolist()) == np.argsort(-keys, kind="stable").tolist(), keys
    for seed in range(50):
        want_rng, got_rng = np.random.default_rng(seed), np.random.default_rng(seed)
        objs = MUGS.askable()
        keys = want_rng.random(len(objs)) ** _target_exponents(MUGS)
        want = [objs[i] for i in np.argsort(-keys, kind="stable")]
        assert target_order(MUGS, got_rng) == want
        assert got_rng.random() == want_rng.random()  # the same draws, no more


def _ordinals_reference(v, head, target):
    """The ordinals as worked out before they were memoised per head (the same arithmetic, all
    of it, for every target)."""
    from refspatial.questions.program import ORDINAL_AXES, answers_to
    from refspatial.questions.refer import MAX_RANK

    ids = [o.object_id for o in v.objects if answers_to(v, o, head.category)
           and head.color in (None, o.color) and o.status != "hidden"]
    if len(ids) < 2:
        return []
    options = []
    for axis, (key, low_end, _) in ORDINAL_AXES.items():
        values = [key(v.objects[i]) for i in ids]
        if not all(np.isfinite(values)):
            continue
        ascending = sorted(ids, key=dict(zip(ids, values)).__getitem__)
        high_end = {"left": "right", "front": "back", "near": "far"}[low_end]
        for end, order in ((low_end, ascending), (high_end, ascending[::-1])):
            rank = order.index(target.object_id) + 1
            if rank <= min(MAX_RANK, (len(ids) + 1) // 2):
                spread = float(np.array(values).std()) / (1.0 if axis != "depth" else 2.0)
                options.append((-spread, rank, Ordinal(axis, end, rank)))
    return [o for *_, o in sorted(options, key=lambda t: (t[0], t[1]))]


def test_ordinals_memoised_per_head_are_the_ones_worked_out_per_target():
    from refspatial.questions.refer import _ordinals

    rng = np.random.default_rng(3)
    views = [MUGS]
    for _ in range(20):  # crowds of few categories and colours, some hidden
        views.append(view(*(obj(i, str(rng.choice(["mug", "bowl"])), str(rng.choice(["red", "blue"])),
                                float(rng.uniform(-0.5, 0.5)), float(rng.uniform(-0.3, 0.3)),
                                status=str(rng.choice(["visible", "visible", "hidden"])))
                            for i in range(7))))
    checked = 0
    for v in views:
        for target in (o for o in v.objects if o.status != "hidden"):  # as the description search asks
            for category in (target.category, None):
                for color in (None, target.color):
                    head = Ref(target.object_id, category, "object", color)
                    want = _ordinals_reference(v, head, target)
                    assert _ordinals(v, head, target) == want == _ordinals(v, head, target)
                    checked += bool(want)
    assert checked > 100


def test_mask_points_are_the_ones_drawn_from_the_eroded_pixels_row_by_row():
    """The eroded pixels kept as indices into the raveled window give the points the frame's
    rows and columns of a 2-D nonzero gave, draw for draw (the order is the rng's to index)."""
    import cv2

    from refspatial.questions.common import POINT_TRIES, _thousandths, sample_mask_points
    from refspatial.relations.masks import padded

    def reference(mask, n, rng, erode):
        m = mask.view(np.uint8)
        x, y, w, h = cv2.boundingRect(m)
        if w == 0:
            return None
        window = padded((slice(y, y + h), slice(x, x + w)), erode + 1, mask.shape)
        rows, cols = np.nonzero(cv2.erode(m[window], np.ones((2 * erode + 1,) * 2, np.uint8)))
        rows, cols = rows + window[0].start, cols + window[1].start
        if len(rows) == 0:
            return None
        points = []
        for _ in range(n * POINT_TRIES):
            k = int(rng.integers(len(rows)))
            h, w = mask.shape
            px, py = _thousandths((int(cols[k]) + 0.5) / w), _thousandths((int(rows[k]) + 0.5) / h)
            if mask[min(int(py * h), h - 1), min(int(px * w), w - 1)]:
                points.append([px, py])
                if len(points) == n:
                    return points
        return None

    rng = np.random.default_rng(12)
    drawn = 0
    for _ in range(150):
        h, w = (int(v) for v in rng.integers(20, 120, 2))
        mask = np.zeros((h, w), dtype=bool)
        for _ in range(int(rng.integers(1, 5))):
            (r0, c0), (dr, dc) = rng.integers(-10, [h, w]), rng.integers(2, 40, 2)
            mask[max(r0, 0):r0 + dr, max(c0, 0):c0 + dc] = True
        erode, seed = int(rng.integers(1, 4)), int(rng.integers(1 << 30))
        want = reference(mask, 5, np.random.default_rng(seed), erode)
        assert sample_mask_points(mask, 5, np.random.default_rng(seed), erode) == want
        drawn += want is not None
    assert drawn > 50
