"""Asset libraries: `refspatial assets import` from YAML, CSV and JSONL annotations, skips and
errors, the import cache, lazy checked loading, and scenes drawing a share of their objects
from a library through every stage (generate, verify, records, USD export)."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from refspatial import library_import
from refspatial.assets import load_catalogue
from refspatial.cli import main
from refspatial.compose import compose
from refspatial.library import LibraryError, attach, library_asset, load_library
from refspatial.library_import import import_library
from refspatial.mesh_texture import face_colours
from refspatial.recipe import load_recipe
from textured import BOX_NOTE, SIDES, write_textured

TINY = str(Path(__file__).parent / "data" / "tiny.yaml")
ROWS = [(f"b{i}/box{i}{'.glb' if i % 2 else '.obj'}", 0.001 * (1 + i / 4), c)
        for i, c in enumerate(("red", "blue", "green", "teal"))]


def _note(scale: float, color: str) -> dict:
    return {k: v for k, v in dict(BOX_NOTE, scale=scale, color=color, collision={"method": "hull"}).items()}


def _source(root: Path, table: str | None) -> Path:
    """Four textured boxes; annotations as YAML beside each, or as one table."""
    src = root / f"src-{table or 'yaml'}"
    for rel, scale, color in ROWS:
        write_textured(src / rel, _note(scale, color))
        if table:
            (src / rel).with_suffix(".yaml").unlink()
    rows = [{"file": rel, **_note(scale, color)} for rel, scale, color in ROWS]
    if table == "csv":
        with open(src / "annotations.csv", "w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows({k: (yaml.safe_dump(v, default_flow_style=True).strip() if isinstance(v, (list, dict))
                                  else v) for k, v in r.items()} for r in rows)
    elif table == "jsonl":
        (src / "annotations.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    return src


@pytest.fixture(scope="module")
def lib(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("lib")
    summary = import_library(_source(root, "csv"), root / "lib", workers=2, cache_dir=root / "cache")
    assert summary.imported == 4 and not summary.skipped
    return root / "lib"


def test_yaml_csv_and_jsonl_annotations_make_the_same_library(lib: Path, tmp_path: Path) -> None:
    shas = {load_library(lib).sha256}
    for table in ("jsonl", None):
        out = tmp_path / f"lib-{table}"
        shas.add(import_library(_source(tmp_path, table), out, workers=1, cache_dir=tmp_path / "c").sha256)
    assert len(shas) == 1
    assert (tmp_path / "lib-jsonl" / "library.json").read_bytes() == (lib / "library.json").read_bytes()


def test_entries_keep_licence_source_size_and_texture(lib: Path) -> None:
    library = load_library(lib)
    assert [e.color for e in library.entries] == ["red", "blue", "green", "teal"]
    entry = library.entries[1]
    assert entry.licence == "CC0-1.0" and entry.source == "https://example.org/box"
    assert entry.size_m == pytest.approx((0.06 * 1.25, 0.04 * 1.25, 0.1 * 1.25))
    asset = library_asset(library, entry, load_catalogue().colors)
    assert asset.texture is not None and asset.visual.face_texcoords is not None
    assert asset.source == entry.source and asset.collision and asset.rgba[:3] == load_catalogue().colors["blue"]
    assert set(map(tuple, face_colours(asset.visual, asset.texture))) <= set(SIDES.values())
    teal = library_asset(library, library.entries[3], load_catalogue().colors)  # no such catalogue colour
    assert teal.rgba[:3] == pytest.approx(tuple(np.asarray(list(SIDES.values())).mean(axis=0) / 255), abs=0.01)


def test_bad_meshes_are_skipped_with_their_reason(tmp_path: Path) -> None:
    src = _source(tmp_path, None)
    (src / "b0" / "box0.yaml").write_text(yaml.safe_dump(dict(_note(0.001, "red"), up="sideways")))
    (src / "b1" / "box1.yaml").unlink()
    (src / "junk.stl").write_text("not a mesh")
    (src / "junk.yaml").write_text(yaml.safe_dump(_note(0.001, "red")))
    skipped: list[tuple[str, str]] = []
    summary = import_library(src, tmp_path / "lib", cache_dir=tmp_path / "c", on_skip=lambda *s: skipped.append(s))
    reasons = dict(skipped)
    assert summary.imported == 2 and set(reasons) == {"b0/box0.obj", "b1/box1.glb", "junk.stl"}
    assert "up: expected one of" in reasons["b0/box0.obj"] and "box1.yaml" in reasons["b1/box1.glb"]
    assert "cannot read the mesh" in reasons["junk.stl"] or "no triangles" in reasons["junk.stl"]


@pytest.mark.parametrize("problem, words", [
    ("both tables", "keep one of them"), ("unknown column", "unknown column 'colour'"),
    ("nothing importable", "none of 1 meshes"), ("out is a file", "not an asset library")])
def test_bad_input_is_one_line_exit_2_and_nothing_written(tmp_path: Path, capsys, monkeypatch, problem: str,
                                                          words: str) -> None:
    monkeypatch.setenv("REFSPATIAL_CACHE", str(tmp_path / "cache"))
    src = _source(tmp_path, "jsonl")
    out = tmp_path / "lib"
    if problem == "both tables":
        (src / "annotations.csv").write_text("file\n")
    elif problem == "unknown column":
        (src / "annotations.jsonl").write_text(json.dumps({"file": "b0/box0.obj", "colour": "red"}) + "\n")
    elif problem == "nothing importable":
        (src / "annotations.jsonl").write_text(json.dumps({"file": "b0/box0.obj"}) + "\n")
    else:
        out.write_text("precious")
    assert main(["assets", "import", str(src), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert words in err[-1] and err[-1].startswith("refspatial: error:")
    assert (out.read_text() == "precious") if problem == "out is a file" else not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no staging folder left
    assert not (tmp_path / "cache" / "library").exists() or problem == "nothing importable"


def test_a_second_import_comes_from_the_cache(lib: Path, tmp_path: Path, monkeypatch) -> None:
    cache = lib.parent / "cache"

    def refuse(*args, **kwargs):
        raise AssertionError("a cached mesh was imported again")

    monkeypatch.setattr(library_import, "import_annotated", refuse)
    summary = import_library(_source(tmp_path, "csv"), tmp_path / "again", cache_dir=cache)
    assert summary.cached == 4 and summary.sha256 == load_library(lib).sha256


def test_changed_files_are_refused_when_read(lib: Path, tmp_path: Path) -> None:
    copy = tmp_path / "copy"
    shutil.copytree(lib, copy)
    library = load_library(copy)
    entry = library.entries[0]
    with np.load(copy / entry.file) as data:
        arrays = {k: data[k] for k in data.files}
    arrays["vertices"] = arrays["vertices"] * 2
    np.savez(copy / entry.file, **arrays)
    with pytest.raises(LibraryError, match="changed since import"):
        library_asset(library, entry, {})
    index = json.loads((copy / "library.json").read_text())
    index["assets"][0]["licence"] = "proprietary"
    (copy / "library.json").write_text(json.dumps(index))
    with pytest.raises(LibraryError, match="do not match its sha256"):
        load_library(copy)


@pytest.mark.parametrize("share", [0.0, 0.5, 1.0])
def test_compose_draws_the_asked_share_from_the_library(lib: Path, share: float) -> None:
    recipe, catalogue = attach(load_recipe(TINY), load_catalogue(), [lib], share)
    counts = [(sum(o.asset.source != "procedural" for o in s.objects), len(s.objects))
              for s in (compose(recipe, catalogue, seed) for seed in range(12))]
    drawn = sum(k for k, _ in counts) / sum(n for _, n in counts)
    assert drawn == pytest.approx(share, abs=0.15) and (share != 1.0 or drawn == 1.0)
    assert compose(recipe, catalogue, 3).objects[0].asset.category == compose(recipe, catalogue, 3).objects[0].asset.category


def test_the_libraries_content_and_share_identify_the_run(lib: Path, tmp_path: Path) -> None:
    base = load_recipe(TINY)
    plain, catalogue = attach(base, load_catalogue(), [], None)
    assert plain is base and catalogue.libraries is None  # no libraries: nothing changes
    a, _ = attach(base, catalogue, [lib], 0.5)
    b, _ = attach(base, catalogue, [shutil.copytree(lib, tmp_path / "moved")], None)  # share defaults to 0.5
    c, _ = attach(base, catalogue, [lib], 0.4)
    assert a.hash == b.hash != c.hash != base.hash
    named = tmp_path / "named.yaml"
    named.write_text(f"extends: {TINY}\nname: tiny\nlibraries: {{paths: [moved], share: 0.5}}\n")
    assert attach(load_recipe(str(named)), catalogue)[0].hash == a.hash  # paths relative to the recipe
    with pytest.raises(LibraryError, match="between 0 and 1"):
        attach(base, catalogue, [lib], 1.5)


def test_library_scenes_pass_every_stage(lib: Path, tmp_path: Path, capsys) -> None:
    args = ["--scenes", "2", "--recipe", TINY, "--assets", str(lib), "--asset-share", "1", "--quiet",
            "--scenes-per-shard", "1"]
    assert main(["generate", *args, "--out", str(tmp_path / "d1"), "--workers", "2"]) == 0
    assert main(["generate", *args, "--out", str(tmp_path / "d2"), "--workers", "1"]) == 0
    for shard in ("shard-00000.mcap", "shard-00001.mcap"):
        assert (tmp_path / "d1" / "shards" / shard).read_bytes() == (tmp_path / "d2" / "shards" / shard).read_bytes()
    assert main(["verify", str(tmp_path / "d1")]) == 0
    manifest = json.loads((tmp_path / "d1" / "manifest.json").read_text())
    assert manifest["libraries"] == [{"path": str(lib.resolve()), "sha256": load_library(lib).sha256, "assets": 4}]
    from refspatial.data import RefSpatialDataset

    objects = [o for i in range(2) for o in RefSpatialDataset(tmp_path / "d1", fields=())[i]["scene"]["objects"]]
    assert objects and all(o["source"] == "https://example.org/box" and o["licence"] == "CC0-1.0" for o in objects)
    assert main(["export", "usd", str(tmp_path / "d1"), str(tmp_path / "usd")]) == 0
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(next((tmp_path / "usd").glob("*.usdc"))))
    mesh = stage.GetPrimAtPath("/World/Objects/obj0/visual")
    assert UsdGeom.PrimvarsAPI(mesh).GetPrimvar("st").GetInterpolation() == UsdGeom.Tokens.faceVarying
    assert len(list((tmp_path / "usd" / "textures").glob("*.png"))) == 1
    capsys.readouterr()
    assert main(["generate", *args, "--out", str(tmp_path / "d3"), "--asset-share", "2"]) == 2
    assert "between 0 and 1" in capsys.readouterr().err and not (tmp_path / "d3").exists()
