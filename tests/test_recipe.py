from pathlib import Path

import pytest

from refspatial.recipe import RecipeError, available, load_recipe


def write(tmp_path: Path, text: str, name: str = "r.yaml") -> str:
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def test_default_recipe_loads_and_is_listed():
    r = load_recipe("tabletop")
    assert "tabletop" in available()
    assert r.name == "tabletop" and len(r.hash) == 64
    assert r["camera"]["pitch_deg"] == [-60, -30]


def test_extends_merges_sections_key_by_key(tiny):
    parent = load_recipe("tabletop")
    assert tiny["camera"]["width"] == 192
    assert tiny["camera"]["pitch_deg"] == parent["camera"]["pitch_deg"]
    assert tiny.hash != parent.hash


def test_hash_ignores_formatting(tmp_path):
    a = load_recipe(write(tmp_path, "extends: tabletop\nname: x\n", "a.yaml"))
    b = load_recipe(write(tmp_path, "# comment\nname:   x\nextends: tabletop\n", "b.yaml"))
    assert a.hash == b.hash


@pytest.mark.parametrize(
    "text, message",
    [
        ("extends: tabletop\nname: x\ncamera: {pitch_deg: [-10, -50]}\n", "camera.pitch_deg"),
        ("extends: tabletop\nname: x\nobjects: {count: [3, 2]}\n", "objects.count"),
        ("extends: tabletop\nname: x\ncamera: {zoom: 2}\n", "camera.zoom: unknown key"),
        ("extends: tabletop\nname: x\nlighting: {}\n", "unknown section 'lighting'"),
        ("extends: tabletop\nname: x\nquestions: {families: {essay: 1}}\n", "unknown question family"),
        ("extends: tabletop\nname: x\ncamera: {width: 0}\n", "camera.width"),
        ("name: x\n", "missing section"),
        ("extends: tabletop\nname: [x\n", "not valid YAML"),
        ("- just\n- a list\n", "expected a mapping"),
        ("extends: nowhere\nname: x\n", "r.yaml: extends: unknown recipe 'nowhere'"),
        ("extends: no/such.yaml\nname: x\n", "no/such.yaml does not exist"),  # looked for beside r.yaml
        ("extends: tabletop\nname: x\ntable: {surface: lawn}\n", "table.surface: expected one of"),
        ("extends: tabletop\nname: x\nfurniture: {count: [2, 1]}\n", "furniture.count"),
        ("extends: tabletop\nname: x\nfurniture: {legs: 4}\n", "furniture.legs: unknown key"),
        ("extends: tabletop\nname: x\nfurniture: 3\n", "furniture: expected a mapping"),
        ("extends: tabletop\nname: x\nobjects: {on_furniture: 2}\n", "objects.on_furniture"),
    ],
)
def test_bad_recipes_name_the_key_to_fix(tmp_path, text, message):
    with pytest.raises(RecipeError) as err:
        load_recipe(write(tmp_path, text))
    assert message in str(err.value)
    assert "\n" not in str(err.value)


def test_extends_cycle_is_reported(tmp_path):
    write(tmp_path, f"extends: {tmp_path / 'b.yaml'}\nname: a\n", "a.yaml")
    write(tmp_path, f"extends: {tmp_path / 'a.yaml'}\nname: b\n", "b.yaml")
    with pytest.raises(RecipeError, match="cycle"):
        load_recipe(str(tmp_path / "a.yaml"))


def test_a_parent_file_is_found_beside_the_recipe_that_names_it(tmp_path, monkeypatch):
    folder = tmp_path / "mine"
    folder.mkdir()
    write(folder, "extends: tabletop\nname: base\ncamera: {width: 320}\n", "base.yaml")
    write(folder, "extends: base.yaml\nname: child\n", "child.yaml")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)  # the parent is not in the folder the command runs from
    assert load_recipe(str(folder / "child.yaml"))["camera"]["width"] == 320


def test_unknown_recipe_lists_known_ones():
    with pytest.raises(RecipeError, match="tabletop"):
        load_recipe("kitchen_of_dreams")


def test_resolved_yaml_loads_alone_to_the_same_hash(tiny, tmp_path):
    alone = tmp_path / "alone.yaml"
    alone.write_text(tiny.resolved_yaml)
    again = load_recipe(str(alone))
    assert "extends" not in tiny.resolved_yaml and again.hash == tiny.hash and again.data == tiny.data


def test_optional_keys_default_without_entering_the_hash(tmp_path):
    """Leaving an optional key out keeps the recipe's hash (and so its scenes) as it was before
    the key existed; option() still answers with the default."""
    plain = load_recipe("tabletop")
    assert "furniture" not in plain.data and "surface" not in plain["table"]
    assert plain.option("table", "surface") == "table" and plain.option("furniture", "count") == [0, 0]
    room = load_recipe("room")
    assert room.option("table", "surface") == "floor" and room.option("furniture", "count")[1] > 0
    explicit = load_recipe(write(tmp_path, "extends: tabletop\nname: tabletop\ntable: {surface: table}\n"))
    assert explicit.option("table", "surface") == "table" and explicit.hash != plain.hash


def test_a_folder_named_like_a_recipe_does_not_hide_it(tmp_path, monkeypatch):
    """`generate --out tabletop` then `--recipe kitchen_counter` (which extends tabletop) from the
    same working directory must still find the shipped recipes."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "tabletop").mkdir()
    (tmp_path / "kitchen_counter").mkdir()
    assert load_recipe("kitchen_counter").name == "kitchen_counter"
