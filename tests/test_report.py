"""The audit report and the aggregates behind it: self-contained HTML, balance warnings, determinism."""

import base64
import re

import cv2
import numpy as np
import pytest

from refspatial.assets import load_catalogue
from refspatial.recipe import load_recipe
from refspatial.report import ReportError, render_html, write_report
from refspatial.shards import generate
from refspatial.stats import (ANSWER_SHARE_MAX, PREDICATE_SHARE_MAX, REGION_SHARE_MAX, answer_threshold,
                              balance_checks, collect, load_manifest, wanted_steps)

from conftest import TINY

TINY_STEPS = load_recipe(str(TINY))["questions"]["steps"]


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("report-dataset")
    generate(out, load_recipe(str(TINY)), load_catalogue(), n_scenes=3, base_seed=11, workers=1, scenes_per_shard=2)
    return out


@pytest.fixture(scope="module")
def stats(dataset):
    return collect(dataset)


@pytest.fixture(scope="module")
def page(stats, dataset):
    return render_html(stats, load_manifest(dataset))


def test_stats_keep_the_keys_scripts_use_and_add_audits(stats):
    for key in ("scenes", "records", "qa", "shards", "rejected", "qa_per_record", "qa_predicates",
                "relation_predicates", "steps", "families", "kinds", "categories", "colors",
                "objects_per_record", "answers"):
        assert key in stats, key
    assert sum(stats["steps"].values()) == stats["qa"]
    objects = sum(stats["categories"].values())
    assert sum(stats["visible_share"]["counts"]) == objects == sum(stats["visibility_status"].values())
    points = stats["answer_points"]
    assert points["count"] == sum(map(sum, points["grid"])) == sum(map(sum, points["grid3"]))
    assert points["count"] >= stats["kinds"].get("point", 0) > 0
    assert sum(stats["question_words"].values()) == stats["qa"]
    assert set(stats["rejected_by_recipe"]) == {"tiny"}
    assert {b["check"] for b in stats["balance"]} >= {"predicate", "region"}


def test_report_is_self_contained(page):
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:|//)""", page, re.I)
    assert "http://" not in page and "https://" not in page
    images = re.findall(r'<img [^>]*src="data:image/png;base64,([A-Za-z0-9+/=]+)"', page)
    assert len(images) >= 7
    for b64 in images:
        raw = base64.b64decode(b64)
        png = cv2.imdecode(np.frombuffer(raw, np.uint8), cv2.IMREAD_COLOR)
        assert png is not None and png.shape[0] >= 100 and png.shape[1] >= 600
        assert b"Software" not in raw and b"tIME" not in raw, "no version or time stamp in the PNG"
    assert len(re.findall(r"<img ", page)) == len(images), "every image must be embedded"


def test_report_lists_every_predicate_and_category(page, stats):
    text = re.sub(r"base64,[A-Za-z0-9+/=]+", "", page)
    assert stats["qa_predicates"] and stats["relation_predicates"]
    for name in (*stats["qa_predicates"], *stats["relation_predicates"], *stats["categories"], *stats["colors"]):
        assert f"<td>{name}</td>" in text, name


def test_report_bytes_depend_on_the_data_only(dataset, page, tmp_path):
    """A second collect and render (another process would do the same) gives the same bytes."""
    again = write_report(collect(dataset), load_manifest(dataset), tmp_path / "sub" / "again.html")
    assert again.read_bytes() == page.encode("utf-8")


def test_report_path_must_be_a_writable_html_file(stats, dataset, tmp_path):
    with pytest.raises(ReportError, match=r"ending in \.html"):
        write_report(stats, load_manifest(dataset), tmp_path / "report.png")
    (tmp_path / "blocker").write_text("a file, not a folder")
    with pytest.raises(ReportError, match="cannot write it"):
        write_report(stats, load_manifest(dataset), tmp_path / "blocker" / "report.html")


def _crafted(predicates: dict, answers: dict, grid3: list) -> dict:
    return {"qa_predicates": predicates, "answers_by_kind": answers,
            "answer_points": {"grid3": grid3, "count": sum(map(sum, grid3))}}


BALANCED = _crafted({"left_of": 30, "right_of": 28, "behind": 25, "in_front_of": 27, "between": 20},
                    {"yes_no": {"(A) yes": 52, "(B) no": 48}, "pick": {"(A)": 49, "(B)": 51}},
                    [[10, 12, 9], [11, 30, 12], [10, 11, 9]])
UNBALANCED = _crafted({"left_of": 300, "right_of": 40, "behind": 30},
                      {"yes_no": {"(A) yes": 20, "(B) no": 180}, "pick": {"(A)": 50, "(B)": 50}},
                      [[1, 2, 1], [2, 200, 3], [1, 2, 1]])


def test_balance_checks_fire_on_dominance_only():
    # Crafted stats name no QA total, so the predicate floor (a shortfall check) has no data here.
    assert [b for b in balance_checks(BALANCED) if b["verdict"] != "ok" and b["check"] != "predicate floor"] == []
    warned = {b["check"]: b for b in balance_checks(UNBALANCED) if b["verdict"] == "warn"}
    assert set(warned) == {"predicate", "answer:yes_no", "region"}
    assert warned["predicate"]["item"] == "left_of" and warned["predicate"]["share"] > PREDICATE_SHARE_MAX
    assert warned["answer:yes_no"]["item"] == "(B) no" and warned["answer:yes_no"]["share"] > ANSWER_SHARE_MAX
    assert warned["region"]["item"] == "middle-centre cell" and warned["region"]["share"] > REGION_SHARE_MAX


def test_answer_threshold_follows_the_option_count():
    """Four boxes: a fair share is 25 %, so 40 % of 1000 answers dominates though it is under 60 %."""
    counts = {"(A)": 400, "(B)": 200, "(C)": 200, "(D)": 200}
    four = {**_crafted({}, {"box": counts}, [[0] * 3] * 3), "answer_options": {"box": 4}}
    row = next(b for b in balance_checks(four) if b["check"] == "answer:box")
    assert row["threshold"] == pytest.approx(0.25 + ANSWER_SHARE_MAX - 0.5) and row["verdict"] == "warn"
    two = {**four, "answer_options": {"box": 2}}
    assert next(b for b in balance_checks(two) if b["check"] == "answer:box")["verdict"] == "ok"


def test_answer_threshold_weighs_mixed_option_counts():
    """Visual choice draws three boxes 70 % of the time and four otherwise: (A) is fairly the
    answer of 0.7/3 + 0.3/4 = 31 % of questions, so 22 of 43 is within noise of that plus the
    margin, where the four-option threshold (35 %) would have warned."""
    mixed = {**_crafted({}, {"box": {"(A)": 8, "(B)": 11, "(C)": 22, "(D)": 2}}, [[0] * 3] * 3),
             "answer_options": {"box": 4}, "answer_option_counts": {"box": {"3": 70, "4": 30}}}
    assert answer_threshold(mixed, "box") == pytest.approx(0.7 / 3 + 0.3 / 4 + ANSWER_SHARE_MAX - 0.5, abs=1e-4)
    assert next(b for b in balance_checks(mixed) if b["check"] == "answer:box")["verdict"] == "watch"
    assert answer_threshold({**mixed, "answer_option_counts": {}}, "box") == pytest.approx(0.35)


def test_small_samples_are_watched_not_warned():
    """24 of 38 answers (63 %) is above the threshold but within a fair coin's noise."""
    rows = balance_checks(_crafted({}, {"pick": {"(A)": 14, "(B)": 24}}, [[0] * 3] * 3))
    verdicts = {b["check"]: b["verdict"] for b in rows}
    assert verdicts == {"predicate": "no data", "answer:pick": "watch", "region": "no data", "predicate floor": "no data"}


def test_a_predicate_under_its_floor_warns_beyond_noise():
    """Each registered predicate in at least 0.5 % of one recipe's QA, 1 % of a mix of recipes."""
    from refspatial.stats import predicate_families

    everything = {p: 200 for p in predicate_families()}
    rows = {b["check"]: b for b in balance_checks({**BALANCED, "qa_predicates": everything, "qa": 10_000})}
    assert rows["predicate floor"]["verdict"] == "ok"
    rare = {**everything, "inside": 10}  # 0.1 % of 10,000 QA: beyond noise under 0.5 %
    row = {b["check"]: b for b in balance_checks({**BALANCED, "qa_predicates": rare, "qa": 10_000})}["predicate floor"]
    assert row["verdict"] == "warn" and row["item"] == "inside"
    mixed = {**everything, "inside": 70}  # 0.7 %: fine for one recipe, short of a mix's 1 %
    single = {b["check"]: b for b in balance_checks({**BALANCED, "qa_predicates": mixed, "qa": 10_000})}
    assert single["predicate floor"]["verdict"] == "ok"
    mix = {b["check"]: b for b in balance_checks({**BALANCED, "qa_predicates": mixed, "qa": 10_000,
                                                  "recipe": "tabletop + shelf"})}
    assert mix["predicate floor"]["verdict"] == "warn"


WANTED = {"1": 0.2, "2": 0.2, "3": 0.2, "4": 0.2, "5": 0.2}


def _steps(by_family: dict) -> dict:
    return {**_crafted({}, {}, [[0] * 3] * 3), "steps_by_family": by_family, "steps_wanted": WANTED}


def test_step_check_warns_when_a_wanted_step_count_falls_far_short():
    """Five-step questions at 4 % where the recipe asks 20 %: below half of it, beyond noise. The
    families that ignore the step count (quantitative: always one step) are not counted."""
    short = _steps({"location": {"1": 300, "2": 300, "3": 200, "4": 160, "5": 40}, "quantitative": {"1": 5000}})
    row = next(b for b in balance_checks(short) if b["check"] == "steps")
    assert (row["item"], row["count"], row["total"], row["verdict"]) == ("5 steps", 40, 1000, "warn")
    assert row["threshold"] == pytest.approx(0.1) and row["upper"] < 0.1 < WANTED["5"]
    even = _steps({"location": {"1": 100, "2": 100, "3": 100}, "placement": {"4": 100, "5": 70}})
    assert next(b for b in balance_checks(even) if b["check"] == "steps")["verdict"] == "ok"
    few = _steps({"identify": {"1": 10, "2": 10, "3": 10, "4": 10, "5": 2}})  # 5 % of 42: within noise
    assert next(b for b in balance_checks(few) if b["check"] == "steps")["verdict"] == "watch"


def test_wanted_steps_come_from_the_recipes_and_must_agree(dataset):
    manifest = load_manifest(dataset)
    mix = wanted_steps([manifest])
    assert mix == {str(k): pytest.approx(w / sum(TINY_STEPS.values())) for k, w in TINY_STEPS.items()}
    other = {**manifest, "recipe_resolved_yaml": "questions:\n  steps: {1: 1}\n"}
    assert wanted_steps([manifest, manifest]) == mix and wanted_steps([manifest, other]) is None
    assert wanted_steps([{k: v for k, v in manifest.items() if k != "recipe_resolved_yaml"}]) is None


def test_steps_by_family_add_up(stats):
    assert sum(sum(c.values()) for c in stats["steps_by_family"].values()) == stats["qa"]
    assert any(b["check"] == "steps" for b in stats["balance"])


def test_warnings_reach_the_page(stats, dataset):
    crafted = {**stats, "qa_predicates": UNBALANCED["qa_predicates"], "answers_by_kind": UNBALANCED["answers_by_kind"]}
    crafted["balance"] = balance_checks(crafted)
    crafted["warnings"] = [b["message"] for b in crafted["balance"] if b["verdict"] == "warn"]
    page = render_html(crafted, load_manifest(dataset))
    items = re.search(r"<ul class=warnings>(.*?)</ul>", page, re.S).group(1)
    assert items.count("<li>") == len(crafted["warnings"]) >= 2
    assert "QA predicates: left_of holds 81%" in items and "yes_no answers: (B) no holds 90%" in items
    assert page.count("<tr class=warn>") == len(crafted["warnings"])


def test_page_shows_the_datasets_own_warnings(page, stats):
    section = page[page.index("<h2>Balance warnings</h2>"):page.index("<table>", page.index("<h2>Balance warnings</h2>"))]
    if stats["warnings"]:
        assert section.count("<li>") == len(stats["warnings"])
    else:
        assert "<p class=ok>no balance warning fired</p>" in section


def test_no_warnings_is_said_plainly_not_in_the_warning_red(stats, dataset):
    """The all-clear is outside the red ``warnings`` list, in the report and in the text."""
    from refspatial.stats import format_text

    calm = {**stats, "warnings": []}
    page = render_html(calm, load_manifest(dataset))
    start = page.index("<h2>Balance warnings</h2>")
    section = page[start:page.index("<table>", start)]
    assert "class=warnings" not in section and "<li>" not in section
    assert re.search(r"<p class=ok>no balance warning fired</p>", section)
    ok_colour = re.search(r"\.ok \{ color: (#[0-9a-f]+); \}", page).group(1)
    assert ok_colour != re.search(r"\.warnings li \{ color: (#[0-9a-f]+); \}", page).group(1)
    assert format_text(calm).splitlines()[-1] == "no balance warning fired"
    warned = format_text({**stats, "warnings": ["QA predicates: left_of holds 81%"]}).splitlines()
    assert warned[-1] == "warning: QA predicates: left_of holds 81%" and "no balance warning fired" not in warned


def test_answer_labels_name_one_word_options_only():
    from refspatial.stats import answer_label

    assert answer_label({"question": "Is it left of the cup? (A) yes (B) no", "answer": "(B)"}) == "(B) no"
    assert answer_label({"question": "Which way? (A) left (B) right", "answer": "(A)"}) == "(A) left"
    assert answer_label({"question": "Which is taller: (A) the red cup or (B) the vase?", "answer": "(A)"}) == "(A)"
