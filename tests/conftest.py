"""Shared fixtures: the tiny recipe and one small generated dataset per test session."""

from __future__ import annotations

from pathlib import Path

import pytest

import refspatial  # noqa: F401  (sets MUJOCO_GL before anything imports mujoco)
from refspatial.assets import load_catalogue
from refspatial.recipe import load_recipe

TINY = Path(__file__).parent / "data" / "tiny.yaml"


@pytest.fixture(scope="session")
def catalogue():
    return load_catalogue()


@pytest.fixture(scope="session")
def tiny():
    return load_recipe(str(TINY))


@pytest.fixture(scope="session")
def tiny_dataset(tmp_path_factory, tiny, catalogue):
    """Eight tiny scenes in three shards, generated once with two workers."""
    from refspatial.shards import generate

    out = tmp_path_factory.mktemp("tiny-dataset")
    generate(out, tiny, catalogue, n_scenes=8, base_seed=7, workers=2, scenes_per_shard=3)
    return out
