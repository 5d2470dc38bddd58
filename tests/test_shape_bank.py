"""Shape variants (refspatial/shape_bank.py): a recipe's `objects.shape_variants` bounds each
category's shapes, and a scene is the same whether its shapes were built or found in the bank."""

from __future__ import annotations

import numpy as np
import pytest

from refspatial import shape_bank
from refspatial.assets import build_asset
from refspatial.compose import SceneRejected, compose
from refspatial.recipe import load_recipe


def _recipe(tmp_path, variants: int | None):
    from conftest import TINY

    path = tmp_path / f"variants-{variants}.yaml"
    line = "" if variants is None else f"objects: {{shape_variants: {variants}}}\n"
    path.write_text(f"extends: {TINY}\nname: variants\n{line}", encoding="utf-8")
    return load_recipe(str(path))


def _scenes(recipe, catalogue, seeds):
    out = []
    for seed in seeds:
        try:
            out.append(compose(recipe, catalogue, seed))
        except SceneRejected:
            continue
    return out


def _shapes(scenes) -> dict[str, set]:
    seen: dict[str, set] = {}
    for scene in scenes:
        for o in scene.objects:
            seen.setdefault(o.asset.category, set()).add(tuple(sorted(o.asset.params.items())))
    return seen


def test_each_category_keeps_to_its_variants(tmp_path, catalogue):
    shapes = _shapes(_scenes(_recipe(tmp_path, 2), catalogue, range(40)))
    assert shapes and max(len(s) for s in shapes.values()) == 2, shapes
    fresh = _shapes(_scenes(_recipe(tmp_path, 0), catalogue, range(40)))
    assert max(len(s) for s in fresh.values()) > 2  # 0: a fresh shape per object, as before the bank


def test_a_scene_is_the_same_built_or_banked(tmp_path, catalogue):
    recipe = _recipe(tmp_path, 3)
    shape_bank.clear()
    cold = _scenes(recipe, catalogue, [5, 6])
    _scenes(recipe, catalogue, range(100, 110))  # other scenes fill the bank in another order
    warm = _scenes(recipe, catalogue, [5, 6])
    assert len(cold) == len(warm) == 2
    for a, b in zip(cold, warm):
        assert [o.pose for o in a.objects] == [o.pose for o in b.objects]
        for x, y in zip(a.objects, b.objects):
            assert np.array_equal(x.asset.visual.vertices_m, y.asset.visual.vertices_m)
            assert np.array_equal(x.asset.visual.texcoords, y.asset.visual.texcoords)
            assert x.asset.params == y.asset.params and x.asset.color == y.asset.color


def test_banked_meshes_cannot_be_changed_in_place(catalogue):
    asset = build_asset(catalogue, "mug", np.random.default_rng(0), shape_variants=4)
    with pytest.raises(ValueError, match="read-only"):
        asset.visual.vertices_m[0, 0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        asset.collision[0].faces[0, 0] = 0


def test_variant_parameters_are_a_pure_function_of_category_ranges_and_number():
    ranges = {"radius_m": (0.03, 0.05), "height_m": (0.08, 0.12)}
    a = shape_bank.variant_params("mug", ranges, 7)
    assert a == shape_bank.variant_params("mug", dict(reversed(ranges.items())), 7)
    assert a != shape_bank.variant_params("mug", ranges, 8) and a != shape_bank.variant_params("cup", ranges, 7)
    assert a != shape_bank.variant_params("mug", {**ranges, "height_m": (0.08, 0.13)}, 7)
    assert all(lo <= a[k] <= hi for k, (lo, hi) in ranges.items())


def test_the_bank_forgets_the_least_recently_used(monkeypatch):
    monkeypatch.setattr(shape_bank, "CAPACITY", 2)
    shape_bank.clear()
    built = []

    def build(k):
        return lambda: built.append(k) or k

    for k in ("a", "b", "a", "c", "a", "b"):
        shape_bank.banked(k, build(k))
    assert built == ["a", "b", "c", "b"] and shape_bank.size() == 2  # "b" was the least recent when "c" came
    shape_bank.clear()


def test_shape_variants_must_be_a_whole_number(tmp_path):
    from refspatial.recipe import RecipeError

    path = tmp_path / "bad.yaml"
    path.write_text("extends: tabletop\nname: bad\nobjects: {shape_variants: 2.5}\n", encoding="utf-8")
    with pytest.raises(RecipeError, match="shape_variants"):
        load_recipe(str(path))
